//! `magcal import` of tlog logs (being written).
