//! Conformance suite for projection backends (filled in below).
