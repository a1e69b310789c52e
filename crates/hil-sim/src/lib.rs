//! hil-sim (skeleton; see its issue).
