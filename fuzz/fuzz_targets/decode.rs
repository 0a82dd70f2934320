//! Arbitrary bytes through the container parser and the whole decoder: each
//! must return `Ok` or `Err`, never panic, and stay within the sample limit.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let limits = qm::Limits::DEFAULT.with_max_samples(1 << 12);
    let _ = qm::codec::container::read(data, &limits);
    let options = qm::DecodeOptions::default().with_limits(limits);
    let _ = qm::codec::decompress(data, &options);
});
