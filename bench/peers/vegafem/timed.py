#!/usr/bin/env python3
"""Run a command under GNU time (`/usr/bin/time -v`), as run.sh needs it.

    timed.py LOG [--mark TEXT] -- COMMAND...

Writes the command's stdout to LOG.out, GNU time's report to LOG.time, the one-minute load
average before and after to LOG.load, and passes the command's stderr through. With --mark, the
process's CPU time (user + sys, all threads, from /proc/PID/stat) at the moment the first
stderr line containing TEXT appears goes to LOG.mark, in seconds: `tetsim bench` prints its
STREAM triad line when the STREAM measurement is done, so that its CPU time can be taken out.
"""
import os
import subprocess
import sys


def load():
    with open("/proc/loadavg") as f:
        return f.read().split()[0]


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    # Fields 14 and 15 of stat (utime, stime) are 12 and 13 after the command name.
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def child_of(pid):
    with open(f"/proc/{pid}/task/{pid}/children") as f:
        children = f.read().split()
    return int(children[0]) if children else None


def main():
    args = sys.argv[1:]
    log, args = args[0], args[1:]
    mark = None
    if args[:1] == ["--mark"]:
        mark, args = args[1], args[2:]
    if args[:1] == ["--"]:
        args = args[1:]
    before = load()
    with open(log + ".out", "w") as out:
        proc = subprocess.Popen(["/usr/bin/time", "-v", "-o", log + ".time", *args],
                                stdout=out, stderr=subprocess.PIPE, text=True)
        for line in proc.stderr:
            sys.stderr.write(line)
            if mark is not None and mark in line:
                pid = child_of(proc.pid)
                with open(log + ".mark", "w") as f:
                    f.write(f"{cpu_seconds(pid):.2f}\n")
                mark = None
        status = proc.wait()
    with open(log + ".load", "w") as f:
        f.write(f"{before} {load()}\n")
    if status != 0:
        sys.exit(f"timed.py: {' '.join(args)} exited with status {status}")


if __name__ == "__main__":
    main()
