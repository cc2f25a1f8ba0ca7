//! The hostile tour, one module per mechanism: each test is a
//! case a hostile user reproduced (files lost, a panic, a silently wrong
//! answer, an unclear error) and failed before its fix.

mod documents;
mod files;
mod input;
mod references;
