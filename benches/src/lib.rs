//! Criterion benches for wavelux live in `benches/`; this library is empty on purpose.
