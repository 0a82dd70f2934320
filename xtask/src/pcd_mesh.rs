//! `cargo xtask pcd-mesh IN.pcd OUT.ply`: a vertex-coloured mesh from an
//! organised RGB-D point cloud (PCL's PCD format), for measuring colour on
//! real scans (docs/appearance.md: Debian `python3-pcl`'s Kinect scan).
//!
//! Reads `binary` or `binary_compressed` (LZF) PCD files with fields `x y
//! z` and `rgb` or `rgba` (packed in a 32-bit value) on a `WIDTH x HEIGHT`
//! grid, triangulates every grid cell whose four points are valid and
//! whose longest side is under 3 times the median of such cells' (so depth
//! jumps stay open), keeps the points used, and writes a PLY with `red
//! green blue`.

use qm::PolyMesh;
use qm::lift::glam::DVec3;

pub fn run(args: &[String]) -> Result<(), String> {
    let [input, output] = args else {
        return Err("usage: cargo xtask pcd-mesh IN.pcd OUT.ply".into());
    };
    let data = std::fs::read(input).map_err(|e| format!("{input}: {e}"))?;
    let cloud = parse(&data).map_err(|e| format!("{input}: {e}"))?;
    let (mesh, colours) = triangulate(&cloud);
    qm::write_coloured_mesh(output, &mesh, &colours).map_err(|e| e.to_string())?;
    println!(
        "{output}: {} vertices, {} triangles",
        mesh.positions.len(),
        mesh.face_count()
    );
    Ok(())
}

/// An organised cloud: a point (or none) and a colour per grid cell.
struct Cloud {
    width: usize,
    height: usize,
    points: Vec<Option<DVec3>>,
    colours: Vec<[u8; 3]>,
}

fn parse(data: &[u8]) -> Result<Cloud, String> {
    let mut fields = Vec::new();
    let mut sizes = Vec::new();
    let (mut width, mut height, mut points, mut kind) = (0, 1, 0, String::new());
    let mut at = 0;
    while kind.is_empty() {
        let end =
            (data[at..].iter().position(|&b| b == b'\n')).ok_or("the header has no DATA line")?;
        let line = String::from_utf8_lossy(&data[at..at + end]).into_owned();
        at += end + 1;
        let mut words = line.split_whitespace();
        let number = |w: Option<&str>| w.and_then(|w| w.parse::<usize>().ok()).unwrap_or(0);
        match words.next() {
            Some("FIELDS") => fields = words.map(str::to_owned).collect(),
            Some("SIZE") => sizes = words.map(|w| w.parse().unwrap_or(0)).collect(),
            Some("WIDTH") => width = number(words.next()),
            Some("HEIGHT") => height = number(words.next()),
            Some("POINTS") => points = number(words.next()),
            Some("DATA") => kind = words.next().unwrap_or("?").to_owned(),
            _ => {}
        }
    }
    if fields.len() != sizes.len() || width * height != points || points == 0 {
        return Err("inconsistent header (FIELDS, SIZE, WIDTH x HEIGHT, POINTS)".into());
    }
    // Column-major (binary_compressed) or point-major (binary) bytes.
    let stride: usize = sizes.iter().sum();
    let (raw, by_column) = match kind.as_str() {
        "binary_compressed" => {
            let word = |k: usize| {
                data.get(at + 4 * k..at + 4 * k + 4)
                    .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize)
            };
            let (packed, size) = word(0).zip(word(1)).ok_or("cut in the data")?;
            let src = data.get(at + 8..at + 8 + packed).ok_or("cut in the data")?;
            (lzf(src, size)?, true)
        }
        "binary" => (data[at..].to_vec(), false),
        other => {
            return Err(format!(
                "DATA {other} is not read (binary, binary_compressed)"
            ));
        }
    };
    if raw.len() < stride * points {
        return Err("the data is shorter than the header says".into());
    }
    let column = |name: &str| -> Result<(usize, usize), String> {
        let k = (fields.iter().position(|f| f == name)).ok_or(format!("no field {name}"))?;
        Ok((sizes[..k].iter().sum(), sizes[k]))
    };
    let word = |(offset, size): (usize, usize), i: usize| -> u32 {
        let at = if by_column {
            offset * points + size * i
        } else {
            stride * i + offset
        };
        u32::from_le_bytes(raw[at..at + 4].try_into().expect("4 bytes"))
    };
    let [x, y, z] = ["x", "y", "z"].map(column);
    let (x, y, z) = (x?, y?, z?);
    let rgb = column("rgb").or_else(|_| column("rgba"))?;
    let mut cloud = Cloud {
        width,
        height,
        points: Vec::with_capacity(points),
        colours: Vec::with_capacity(points),
    };
    for i in 0..points {
        let p = [x, y, z].map(|c| f32::from_bits(word(c, i)) as f64);
        let p = DVec3::from_array(p);
        cloud.points.push(p.is_finite().then_some(p));
        let c = word(rgb, i);
        cloud
            .colours
            .push([(c >> 16) as u8, (c >> 8) as u8, c as u8]);
    }
    Ok(cloud)
}

/// LZF decompression (as PCL writes it) of `src` into `size` bytes.
fn lzf(src: &[u8], size: usize) -> Result<Vec<u8>, String> {
    let bad = || "corrupt LZF data".to_string();
    let mut out = Vec::with_capacity(size);
    let mut i = 0;
    while i < src.len() {
        let ctrl = src[i] as usize;
        i += 1;
        if ctrl < 32 {
            let literal = src.get(i..i + ctrl + 1).ok_or_else(bad)?;
            out.extend_from_slice(literal);
            i += ctrl + 1;
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                len += *src.get(i).ok_or_else(bad)? as usize;
                i += 1;
            }
            let back = ((ctrl & 0x1f) << 8) + *src.get(i).ok_or_else(bad)? as usize + 1;
            i += 1;
            let from = out.len().checked_sub(back).ok_or_else(bad)?;
            for k in 0..len + 2 {
                out.push(out[from + k]);
            }
        }
    }
    if out.len() == size {
        Ok(out)
    } else {
        Err(bad())
    }
}

/// Two triangles per grid cell of four valid points whose longest side is
/// under 3 times the median; the points used, with their colours.
fn triangulate(cloud: &Cloud) -> (PolyMesh, Vec<[u8; 3]>) {
    let (w, h) = (cloud.width, cloud.height);
    let cells: Vec<([usize; 4], f64)> = (0..h.saturating_sub(1))
        .flat_map(|r| (0..w.saturating_sub(1)).map(move |c| r * w + c))
        .filter_map(|a| {
            let corners = [a, a + 1, a + w + 1, a + w];
            let p = corners.map(|k| cloud.points[k]);
            let p = [p[0]?, p[1]?, p[2]?, p[3]?];
            let longest = (0..4)
                .map(|k| p[k].distance(p[(k + 1) % 4]))
                .fold(0.0, f64::max);
            Some((corners, longest))
        })
        .collect();
    let mut sides: Vec<f64> = cells.iter().map(|c| c.1).collect();
    sides.sort_by(f64::total_cmp);
    let limit = 3.0 * sides.get(sides.len() / 2).copied().unwrap_or(0.0);
    let mut index = vec![u32::MAX; cloud.points.len()];
    let mut positions = Vec::new();
    let mut colours = Vec::new();
    let mut triangles = Vec::new();
    for (corners, longest) in cells {
        if longest >= limit {
            continue;
        }
        let v = corners.map(|k| {
            if index[k] == u32::MAX {
                index[k] = positions.len() as u32;
                positions.push(cloud.points[k].expect("valid"));
                colours.push(cloud.colours[k]);
            }
            index[k]
        });
        triangles.push([v[0], v[1], v[2]]);
        triangles.push([v[0], v[2], v[3]]);
    }
    (PolyMesh::from_faces(positions, &triangles), colours)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lzf_literals_and_back_references() {
        // "abcabcabc": a literal run of 3, then a back reference of 6 bytes
        // (length field 4) to 3 bytes back.
        let packed = [2, b'a', b'b', b'c', 4 << 5, 2];
        assert_eq!(lzf(&packed, 9).unwrap(), b"abcabcabc");
        assert!(
            lzf(&[4 << 5, 9], 6).is_err(),
            "a reference before the start"
        );
    }

    #[test]
    fn a_grid_with_a_hole_and_a_jump() {
        // 3 x 3 points, the centre missing in one cloud: 8 or 0 triangles.
        let grid = |hole: bool| Cloud {
            width: 3,
            height: 3,
            points: (0..9)
                .map(|k| {
                    (!(hole && k == 4)).then(|| DVec3::new((k % 3) as f64, (k / 3) as f64, 0.0))
                })
                .collect(),
            colours: (0..9).map(|k| [k as u8; 3]).collect(),
        };
        let (mesh, colours) = triangulate(&grid(false));
        assert_eq!(
            (mesh.positions.len(), mesh.face_count(), colours.len()),
            (9, 8, 9)
        );
        let (mesh, _) = triangulate(&grid(true));
        assert_eq!(mesh.face_count(), 0);
    }
}
