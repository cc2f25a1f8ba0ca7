//! Hostile cases: references.
