//! stub
pub use qm_tree;
