//! Extended targets as shapes: rectangles and circles fitted to the segmented map (work in
//! progress).
