//! `magcal import` of nmea2000 logs (being written).
