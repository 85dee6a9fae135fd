//! wavelux-render: see the crate description; being built (this placeholder is replaced by the crate's modules).
