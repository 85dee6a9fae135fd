//! wavelux-tests: cross-crate ground truth. The tests live in `tests/integration/`;
//! this library holds what they share with the `transfer-accuracy` reproduction of
//! `xtask`: the analytic catalogue of configuration factors ([`catalogue`]).

pub mod catalogue;
