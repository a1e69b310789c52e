//! planner (skeleton; see its issue).
