//! Trim masks of virtual supports (VirtualMesh §4, §5.4), re-exported from
//! `wavelux-support`, where they live since the glossy method uses them too.

pub use wavelux_support::mask::*;
