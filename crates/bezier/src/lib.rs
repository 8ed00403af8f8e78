//! Bézier curves (work in progress).
