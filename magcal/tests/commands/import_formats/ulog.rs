//! `magcal import` of ulog logs (being written).
