//! Hostile input: the decoder and the readers survive anything.

mod common;
