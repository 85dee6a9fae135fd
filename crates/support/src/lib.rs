//! wavelux-support: unit-square supports of surfaces and their trim masks (Virtual
//! Mesh §3–§4, Ziegler §3.3.1), shared by the method crates that put a basis on
//! surfaces (`wavelux-solver` for diffuse radiosity, `wavelux-glossy` for radiance).
//!
//! Every lit side of a scene surface gets a map `χ: [0,1]² → surface` with a constant
//! Jacobian wherever one exists (an *equal-area* map, so an `L²`-orthonormal basis on
//! the square stays orthonormal on the surface) and, for surfaces no exact map covers
//! (oblique polygons with holes or arcs, trimmed curved patches), a *virtual support*:
//! an enclosing parallelogram plus a trim [`Mask`] that tells real points from virtual
//! ones.
//!
//! Modules:
//! - [`piece`]: [`Support`] and [`SupportMap`]: point, normal, Jacobian, coverage,
//!   real fractions and nearest real points of one support;
//! - [`mask`]: exact trim masks (segments and circular arcs, Green's theorem);
//! - [`set`]: [`build_supports`], the supports of a whole scene, one [`SideSupport`]
//!   per lit side with its material index;
//! - [`trace`]: a support's exact primitive ([`Support::primitive`]) and the inverse
//!   of its map at a ray hit ([`SupportMap::invert`]), for the renderer and the glossy
//!   method's rays.
//!
//! **Invariant:** no material model here (a side carries its material index only);
//! no dependency on any method crate.

pub mod error;
pub mod mask;
pub mod piece;
pub mod set;
pub mod trace;

pub use error::SupportError;
pub use mask::{Coverage, Mask};
pub use piece::{Support, SupportMap};
pub use set::{Side, SideSupport, SupportSet, build_supports};
pub use wavelux_param::ParamKind;
