//! Wavefront material libraries (`.mtl`), as far as the base colour goes.
//!
//! Read: `newmtl NAME`, `Kd r g b` (the diffuse colour), `d` (dissolve, the
//! alpha) or `Tr` (transparency, 1 - alpha), and `map_Kd [options] FILE`.
//! The options of a map statement are skipped with their arguments (`-s`,
//! `-o` and `-t` take one to three numbers, `-mm` two, the others one), so
//! that the file name is what follows them, spaces included; options that
//! change how the image maps (`-s`, `-o`, `-t`, `-clamp`, `-mm`, `-cc`) are
//! reported as not applied. Other maps (`map_Ks`, `bump`, `norm`, ...) are
//! reported; the remaining statements (`Ka`, `Ks`, `Ns`, `illum`, ...) are
//! material parameters beyond the base colour and are part of what the
//! material itself stands for.

use crate::asset::add_dropped;
use crate::{AttributeKind, Dropped};

/// One `newmtl` section.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct MtlMaterial {
    pub name: String,
    /// `Kd`.
    pub diffuse: Option<[f32; 3]>,
    /// `d`, or 1 - `Tr`.
    pub alpha: Option<f32>,
    /// The file name of `map_Kd`, as written (relative to the library).
    pub map: Option<String>,
}

/// Map statements other than `map_Kd`.
const OTHER_MAPS: [&str; 14] = [
    "map_Ka", "map_Ks", "map_Ns", "map_d", "map_Tr", "map_bump", "map_Bump", "bump", "disp",
    "decal", "refl", "norm", "map_Pr", "map_Pm",
];

/// Parses a library; `label` names it in the dropped list. Lines that do not
/// parse are reported, never fatal.
pub(crate) fn parse(bytes: &[u8], label: &str, dropped: &mut Vec<Dropped>) -> Vec<MtlMaterial> {
    let mut materials: Vec<MtlMaterial> = Vec::new();
    for (number, line) in crate::numbered_lines(bytes) {
        let Ok(text) = std::str::from_utf8(crate::strip_comment(line)) else {
            let detail = format!("{label}: line {number} is not text");
            add_dropped(dropped, AttributeKind::Materials, 0, detail);
            continue;
        };
        let text = text.trim();
        let (keyword, rest) = text.split_once(char::is_whitespace).unwrap_or((text, ""));
        let rest = rest.trim();
        let bad = |dropped: &mut Vec<Dropped>| {
            let detail = format!("{label}: line {number}: cannot read {keyword:?}");
            add_dropped(dropped, AttributeKind::Materials, 0, detail);
        };
        if keyword == "newmtl" {
            materials.push(MtlMaterial {
                name: rest.to_owned(),
                ..MtlMaterial::default()
            });
            continue;
        }
        let Some(material) = materials.last_mut() else {
            continue;
        };
        match keyword {
            "Kd" => match numbers(rest) {
                // `Kd spectral` and `Kd xyz` forms are not RGB.
                Some(v) if v.len() == 3 && in_unit(&v) => {
                    material.diffuse = Some([v[0], v[1], v[2]])
                }
                Some(v) if v.len() == 1 && in_unit(&v) => material.diffuse = Some([v[0]; 3]),
                _ => bad(dropped),
            },
            "d" | "Tr" => match numbers(rest.trim_start_matches("-halo").trim()) {
                Some(v) if v.len() == 1 && in_unit(&v) => {
                    material.alpha = Some(if keyword == "d" { v[0] } else { 1.0 - v[0] });
                }
                _ => bad(dropped),
            },
            "map_Kd" => match map_file(rest) {
                Some((file, ignored)) => {
                    if !ignored.is_empty() {
                        let detail =
                            format!("{label}: map_Kd options {} not applied", ignored.join(" "));
                        add_dropped(
                            dropped,
                            AttributeKind::Properties,
                            ignored.len() as u64,
                            detail,
                        );
                    }
                    material.map = Some(file);
                }
                None => bad(dropped),
            },
            other if OTHER_MAPS.contains(&other) => {
                let file = map_file(rest).map_or_else(String::new, |(f, _)| format!(" {f}"));
                let detail = format!("{other}{file} of material {:?}", material.name);
                add_dropped(dropped, AttributeKind::OtherMaps, 1, detail);
            }
            _ => {}
        }
    }
    materials
}

fn numbers(text: &str) -> Option<Vec<f32>> {
    text.split_ascii_whitespace()
        .map(|t| t.parse::<f32>().ok().filter(|v| v.is_finite()))
        .collect()
}

fn in_unit(values: &[f32]) -> bool {
    values.iter().all(|v| (0.0..=1.0).contains(v))
}

/// How many arguments a map option takes: at least, at most.
fn option_arguments(option: &str) -> Option<(usize, usize)> {
    Some(match option {
        "-o" | "-s" | "-t" => (1, 3),
        "-mm" => (2, 2),
        "-blendu" | "-blendv" | "-boost" | "-texres" | "-clamp" | "-bm" | "-imfchan" | "-type"
        | "-cc" => (1, 1),
        _ => return None,
    })
}

/// The file name of a map statement's arguments, and the options that
/// change how the image maps and are not applied. `None` when nothing is
/// left for a file name or an option is cut short.
pub(crate) fn map_file(args: &str) -> Option<(String, Vec<String>)> {
    let tokens: Vec<&str> = args.split_ascii_whitespace().collect();
    let mut ignored = Vec::new();
    let mut k = 0;
    while let Some(&token) = tokens.get(k) {
        let Some((least, most)) = option_arguments(token) else {
            break;
        };
        k += 1;
        let mut taken = 0;
        while taken < most {
            let Some(arg) = tokens.get(k) else { break };
            // Optional numeric arguments stop at the first word that is not
            // a number; the required ones are taken as they come.
            if taken >= least && arg.parse::<f64>().is_err() {
                break;
            }
            taken += 1;
            k += 1;
        }
        if taken < least {
            return None;
        }
        let is_off = tokens.get(k - 1) == Some(&"off");
        let neutral = match token {
            "-bm" | "-blendu" | "-blendv" | "-boost" | "-texres" | "-imfchan" | "-type" => true,
            "-clamp" | "-cc" => is_off,
            _ => false,
        };
        if !neutral {
            ignored.push(token.to_owned());
        }
    }
    // File names may hold spaces: the rest of the line is the name.
    let name = tokens[k.min(tokens.len())..].join(" ");
    (!name.is_empty()).then_some((name, ignored))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_options_are_skipped_with_their_arguments() {
        let (file, ignored) = map_file("-s 1 1 1 -o 0.5 0 -bm 0.2 tex/wood grain.png").unwrap();
        assert_eq!(file, "tex/wood grain.png");
        assert_eq!(ignored, ["-s", "-o"]);
        let (file, ignored) = map_file("-clamp off -mm 0 1 -s 2 3.png").unwrap();
        assert_eq!(file, "3.png", "optional numbers end at a word that is none");
        assert_eq!(ignored, ["-mm", "-s"]);
        let (file, ignored) = map_file("-s 2 skin.jpg").unwrap();
        assert_eq!((file.as_str(), ignored.len()), ("skin.jpg", 1));
        assert_eq!(map_file("diffuse.png").unwrap().0, "diffuse.png");
        assert_eq!(map_file("-bm 0.3"), None, "no file name");
        assert_eq!(map_file("-mm 1"), None, "an option cut short");
        assert_eq!(map_file(""), None);
    }

    #[test]
    fn materials_with_colour_alpha_and_maps() {
        let text = b"# lib\nnewmtl red\nKd 1 0 0\nd 0.5\nmap_Kd -s 1 1 1 red.png\n\
            map_Bump n.png\nnewmtl grey\nKd 0.5\nTr 0.25\nKs 1 1 1\nnewmtl bad\nKd 2 0 0\n";
        let mut dropped = Vec::new();
        let m = parse(text, "a.mtl", &mut dropped);
        assert_eq!(m.len(), 3);
        assert_eq!(m[0].name, "red");
        assert_eq!(m[0].diffuse, Some([1.0, 0.0, 0.0]));
        assert_eq!(m[0].alpha, Some(0.5));
        assert_eq!(m[0].map.as_deref(), Some("red.png"));
        assert_eq!(m[1].diffuse, Some([0.5; 3]));
        assert_eq!(m[1].alpha, Some(0.75));
        assert_eq!(m[2].diffuse, None, "out of 0..1");
        let kinds: Vec<AttributeKind> = dropped.iter().map(|d| d.kind).collect();
        assert_eq!(
            kinds,
            [
                AttributeKind::Properties,
                AttributeKind::OtherMaps,
                AttributeKind::Materials
            ]
        );
        assert!(dropped[2].detail.contains("line 12"), "{:?}", dropped[2]);
    }
}
