//! Vehicle models (being written).
