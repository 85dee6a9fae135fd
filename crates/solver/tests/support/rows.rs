//! Leaf row sums of a solved operator (irradiance from unit radiosity on every leaf),
//! shared by `closure.rs` and `virtual_mesh.rs` (included with `#[path]`).

use wavelux_solver::{NodeKey, Solution};

/// Unit radiosity on every leaf (coefficient `√area` on the constant function).
pub fn ones(sol: &Solution) -> Vec<f64> {
    let sys = sol.system();
    let n = sys.hierarchy().n();
    let mut x = vec![0.0; sys.dim()];
    for (l, &i) in sys.hierarchy().leaves().iter().enumerate() {
        x[l * n] = sys.node_area[i as usize].sqrt();
    }
    x
}

/// Each receiving leaf (some reflectance non-zero) and its row sum: its irradiance
/// when every leaf has unit radiosity, the sum of its form factors as the operator
/// (links and closure) has them.
pub fn leaf_rows(sol: &Solution) -> Vec<(NodeKey, f64)> {
    let sys = sol.system();
    let h = sys.hierarchy();
    let n = h.n();
    let irr = sys.irradiance(&ones(sol));
    h.leaves()
        .iter()
        .enumerate()
        .filter(|(l, _)| sys.leaf_rho[*l].iter().any(|&r| r != 0.0))
        .map(|(l, &i)| {
            let f = irr[l * n] / sys.node_area[i as usize].sqrt();
            (h.keys()[i as usize], f)
        })
        .collect()
}
