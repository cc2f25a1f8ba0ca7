//! The host side of the magcal stack, laid out by what a reader looks for:
//!
//! * [`board`]: the board client — the serial link ([`board::BoardClient`]),
//!   the QEMU board's sensor feed, the QEMU launcher, document ↔ board
//!   coefficients;
//! * [`doc`]: the documents and their typed parts — the calibration
//!   document ([`doc::CalDoc`]), its quality and results, the reference and
//!   its check, the integrity counts — and every limit a document is
//!   checked against: the floor every other module stands on;
//! * [`data`]: tables (CSV), recordings, logs and their importers;
//! * [`compute`]: the fits on recordings and the one calibration chain that
//!   the session, the simulator's scenario harness, the bench and the CLI call;
//! * [`export`]: a calibration in ArduPilot's or PX4's parameters;
//! * [`geomag`]: IGRF-14 and WMM2025, and the [`geomag::Site`];
//! * [`session`]: the calibration session for any vehicle;
//! * [`report`]: figures and an HTML page;
//! * [`procedure`]: the field procedure's limits (the session's gates, the
//!   report's marks), a leaf both import;
//!
//! The layers, lowest first (each uses only its own and those below it;
//! `tests/layering.rs` holds them): `files`, `geomag`, `procedure` < `doc`
//! < `data` < `compute` < `board`, `export`, `report` < `session`.
//!
//! These layers are the whole public surface: each re-exports what callers
//! outside the crate use (`compute::fit_recording`, `doc::CalDoc`), and the
//! modules inside a layer are `pub(crate)`. The one deeper public path is
//! the column registry's names, [`data::col`].
//!
//! The `magcal` binary (crate `magcal`) is a thin clap front end over this
//! library, and the field-test simulator is a crate of its own
//! (`magcal-sim`) that this library does not depend on. Errors here are
//! typed (`thiserror`).
#![deny(missing_docs)]
// `!(x > 0)` is deliberate: it rejects NaN along with the out-of-range.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod board;
pub mod compute;
pub mod data;
pub mod doc;
pub mod export;
pub mod files;
pub mod geomag;
pub mod procedure;
pub mod report;
pub mod session;
