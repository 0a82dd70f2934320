//! stub
pub use qm_lift;
