//! Subcommands of the `tetsim` binary: argument structs and dispatch, no physics.

pub mod mesh;
