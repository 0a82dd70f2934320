//! Throughput of the codec on a semi-regular mesh of 1.57M samples (a cube
//! refined 9 times): lifting forward + inverse, the bit-plane coder, and
//! whole-file decoding of the complete stream and of prefixes (from a
//! coarse preview on), and a stream shown after each of 16 chunks, decoded
//! from scratch or resumed.
//!
//! Run with `cargo bench --bench codec`; figures are in coefficients
//! (samples) per second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use qm::lift::{Lifting, Quantizer, UpdateRule, synthetic::bumpy_sphere};
use qm::{DecodeOptions, EncodeOptions, Frames};

const LEVEL: u32 = 9;

fn codec(c: &mut Criterion) {
    let mesh = bumpy_sphere(LEVEL);
    let layout = mesh.layout();
    let samples = layout.sample_count() as u64;
    let quantized = Quantizer::fit(mesh.positions(), 16)
        .unwrap()
        .quantize_all(mesh.positions());

    let mut group = c.benchmark_group("lifting");
    group
        .sample_size(10)
        .throughput(Throughput::Elements(samples));
    for (name, frames) in [("forward+inverse", false), ("forward+inverse/frames", true)] {
        group.bench_function(name, |b| {
            let lifting = Lifting::new(layout, UpdateRule::MeanPreserving).with_frames(frames);
            let mut data = quantized.clone();
            b.iter(|| {
                lifting.forward(&mut data);
                lifting.inverse(&mut data);
            })
        });
    }
    group.finish();

    let full = qm::codec::compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
    let mut group = c.benchmark_group("codec");
    group
        .sample_size(10)
        .throughput(Throughput::Elements(samples));
    // The default tries two frame sources and keeps one, then measures
    // the stream's cuts for holds; one fixed source without holds is a
    // single encoding.
    group.bench_function("encode/lossless", |b| {
        b.iter(|| qm::codec::compress(&mesh, &EncodeOptions::DEFAULT).unwrap())
    });
    let no_holds = EncodeOptions::DEFAULT.with_holds(false);
    group.bench_function("encode/lossless-no-holds", |b| {
        b.iter(|| qm::codec::compress(&mesh, &no_holds).unwrap())
    });
    let one_source = no_holds.with_frame_source(Frames::ParentsFrom(3));
    group.bench_function("encode/lossless-one-frame-source", |b| {
        b.iter(|| qm::codec::compress(&mesh, &one_source).unwrap())
    });
    group.bench_function("decode/lossless", |b| {
        b.iter(|| qm::codec::decompress(&full.bytes, &DecodeOptions::default()).unwrap())
    });
    // A prefix of about 1 byte per 20 samples: a typical streaming preview;
    // 1 per 400 is a first coarse one, whose decoder builds only the
    // levels the bytes reach (docs/scale.md, "Decoding a prefix").
    for (name, bytes) in [
        ("decode/prefix-1:400", samples as usize / 400),
        ("decode/prefix-1:20", samples as usize / 20),
        ("decode/prefix-1:4", samples as usize / 4),
    ] {
        let options = DecodeOptions::default().with_max_bytes(Some(bytes));
        group.bench_function(name, |b| {
            b.iter(|| qm::codec::decompress(&full.bytes, &options).unwrap())
        });
    }
    group.finish();

    // A viewer receiving the lossless file in 16 equal chunks and showing
    // the mesh after each: decoding every prefix from the start, against one
    // `Decoder` that resumes from its last complete pass.
    let mut group = c.benchmark_group("stream-16-chunks");
    group
        .sample_size(10)
        .throughput(Throughput::Elements(samples));
    let cuts: Vec<usize> = (1..=16).map(|k| full.bytes.len() * k / 16).collect();
    group.bench_function("from-scratch", |b| {
        b.iter(|| {
            for &cut in &cuts {
                let options = DecodeOptions::default().with_max_bytes(Some(cut));
                qm::codec::decompress(&full.bytes, &options).unwrap();
            }
        })
    });
    group.bench_function("resuming", |b| {
        b.iter(|| {
            let mut decoder = qm::Decoder::new(&full.bytes, &qm::Limits::DEFAULT).unwrap();
            let start = decoder.stream_start();
            let mut values = Vec::new();
            for &cut in &cuts {
                decoder.decode_into(&full.bytes[start..cut], None, None, &mut values);
            }
        })
    });
    group.finish();
}

criterion_group!(benches, codec);
criterion_main!(benches);
