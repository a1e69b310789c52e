//! Shape inverse kinematics (skeleton).
