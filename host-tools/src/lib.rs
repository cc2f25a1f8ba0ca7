//! The host side of the magcal stack, laid out by what a reader looks for:
//!
//! * [`board`]: the board client — the serial link ([`board::BoardClient`]),
//!   the QEMU board's sensor feed, the QEMU launcher, document ↔ board
//!   coefficients;
//! * [`data`]: recordings (CSV), the calibration document (JSON) and the
//!   typed results inside them;
//! * [`compute`]: the fits on recordings and the one calibration chain that
//!   the session, the simulator's scenario harness, the bench and the CLI call;
//! * [`export`]: a calibration in ArduPilot's or PX4's parameters;
//! * [`geomag`]: IGRF-14 and WMM2025, and the [`geomag::Site`];
//! * [`session`]: the calibration session for any vehicle;
//! * [`report`]: figures and an HTML page;
//! * [`procedure`]: the field procedure's limits (the session's gates, the
//!   report's marks), a leaf both import;
//! * [`integrity_evidence`]: the "recalibrate" rule on a run's per-sample
//!   integrity, a leaf the session and `magcal log` both call.
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
pub mod export;
pub mod files;
pub mod geomag;
pub mod integrity_evidence;
pub mod procedure;
pub mod report;
pub mod session;
