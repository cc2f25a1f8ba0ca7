//! The host side of the magcal stack: the serial link to the board, the QEMU
//! board used in tests and the demo, and (as issues land) recordings, fits
//! and reports. The `magcal` binary is a thin clap front end over this
//! library; errors here are typed ([`link::LinkError`], [`qemu::QemuError`]).
#![deny(missing_docs)]

pub mod caldoc;
pub mod igrf;
pub mod link;
pub mod pipeline;
pub mod qemu;
pub mod recording;
pub mod report;
pub mod scenario;
pub mod session;
pub mod sim;
