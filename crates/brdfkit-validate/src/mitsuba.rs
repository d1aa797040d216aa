//! The Mitsuba 3 cross-check.
