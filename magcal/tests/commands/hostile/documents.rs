//! Hostile cases: documents.
