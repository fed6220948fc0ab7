"""Write bumpy_ball.obj and bumpy_ball.mtl: a detailed render surface for ball.node/.ele.

A latitude-longitude sphere of radius 1 (the tet ball's unit) with bumps of 3 % of the radius,
quads between the poles and triangles at them, texture coordinates (with the seam where
longitude wraps), two groups (north, south) and two materials in alternating bands.
Standard library only: `python3 make_bumpy_ball.py` in this folder.
"""

import math

LON, LAT = 128, 64


def radius(theta, phi):
    return 1.0 + 0.03 * math.sin(6 * theta) * math.cos(5 * phi)


def main():
    v, vt = [], []
    for i in range(1, LAT):  # rings without the poles
        theta = math.pi * i / LAT
        for j in range(LON):
            phi = 2 * math.pi * j / LON
            r = radius(theta, phi)
            v.append((r * math.sin(theta) * math.cos(phi), r * math.cos(theta),
                      r * math.sin(theta) * math.sin(phi)))
    north, south = len(v) + 1, len(v) + 2
    v += [(0.0, radius(0, 0), 0.0), (0.0, -radius(math.pi, 0), 0.0)]
    for i in range(LAT + 1):
        for j in range(LON + 1):  # one more column: the seam's texture coordinates
            vt.append((j / LON, 1 - i / LAT))

    def vid(i, j):  # ring i in 1..LAT-1
        return (i - 1) * LON + (j % LON) + 1

    def tid(i, j):
        return i * (LON + 1) + j + 1

    with open("bumpy_ball.obj", "w") as f:
        f.write("# bumpy ball: render surface for ball.node/.ele (see make_bumpy_ball.py)\n")
        f.write("mtllib bumpy_ball.mtl\no bumpy_ball\n")
        for p in v:
            f.write("v %.6f %.6f %.6f\n" % p)
        for t in vt:
            f.write("vt %.6f %.6f\n" % t)
        f.write("s 1\n")
        for half, rows in (("north", range(0, LAT // 2)), ("south", range(LAT // 2, LAT))):
            f.write("g %s\n" % half)
            for i in rows:
                f.write("usemtl %s\n" % ("orange" if (i // 8) % 2 == 0 else "cream"))
                for j in range(LON):
                    # Faces wind counter-clockwise seen from outside.
                    if i == 0:
                        f.write("f %d/%d %d/%d %d/%d\n" % (north, tid(0, j), vid(1, j + 1),
                                tid(1, j + 1), vid(1, j), tid(1, j)))
                    elif i == LAT - 1:
                        f.write("f %d/%d %d/%d %d/%d\n" % (vid(i, j), tid(i, j), vid(i, j + 1),
                                tid(i, j + 1), south, tid(LAT, j)))
                    else:
                        f.write("f %d/%d %d/%d %d/%d %d/%d\n" % (
                            vid(i, j), tid(i, j), vid(i, j + 1), tid(i, j + 1),
                            vid(i + 1, j + 1), tid(i + 1, j + 1), vid(i + 1, j), tid(i + 1, j)))
    with open("bumpy_ball.mtl", "w") as f:
        f.write("newmtl orange\nKd 0.95 0.45 0.1\nd 1.0\n\nnewmtl cream\nKd 0.95 0.9 0.75\nd 1.0\n")


if __name__ == "__main__":
    main()
