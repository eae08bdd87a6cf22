//! Helpers for tests and benchmarks, behind the non-default cargo feature `testkit` (no
//! dependencies either way): an application needs none of them.
//!
//! - [`synthetic`]: generated operators, valid and deterministic, of any size;
//! - [`reference`](mod@reference): the f64 evaluation of a file, the yardstick of the fast paths;
//! - [`bvh`]: a BVH builder for files made in memory (the runtime itself never builds one);
//! - [`baseline`]: the papers' dense-`V_k` evaluation, for `lrr bench runtime`;
//! - [`faces`]: a small file whose elements are drawn through display faces (format 1.4).

pub mod baseline;
pub mod bvh;
pub mod faces;
pub mod reference;
pub mod synthetic;
