//! Mesh file readers and writers (in progress).
