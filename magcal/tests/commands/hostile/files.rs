//! Hostile cases: files.
