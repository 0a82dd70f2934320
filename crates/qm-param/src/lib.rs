//! From an input mesh to a semi-regular quad mesh (in progress).
