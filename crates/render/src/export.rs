//! Exports of a solution: glTF with baked per-vertex radiosity and per-surface
//! lightmap EXRs (being built).
