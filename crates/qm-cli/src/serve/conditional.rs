//! What a GET or HEAD of one file gets, given its validators and the
//! request's conditional and range headers (RFC 9110, sections 13.2.2 and
//! 14.2): preconditions in the RFC's order (`If-Match`,
//! `If-Unmodified-Since`, `If-None-Match`, `If-Modified-Since`), then
//! `If-Range` and a single byte range. Anything but one byte range (a list
//! of ranges, another unit, a malformed value) is ignored and the whole file
//! is the answer, as the RFC allows.

use std::time::SystemTime;

/// The request headers that decide the answer, as sent.
#[derive(Default)]
pub struct Conditions<'a> {
    pub if_match: Option<&'a str>,
    pub if_none_match: Option<&'a str>,
    pub if_modified_since: Option<&'a str>,
    pub if_unmodified_since: Option<&'a str>,
    pub if_range: Option<&'a str>,
    pub range: Option<&'a str>,
}

/// What the file's current version is.
pub struct Version<'a> {
    /// A strong entity tag, quotes included.
    pub etag: &'a str,
    /// In whole seconds.
    pub modified: SystemTime,
    pub len: u64,
}

#[derive(Debug, PartialEq, Eq)]
pub enum Answer {
    /// 200 with the whole file.
    Whole,
    /// 206 with bytes `start..=end`.
    Part { start: u64, end: u64 },
    /// 304.
    NotModified,
    /// 412.
    PreconditionFailed,
    /// 416.
    Unsatisfiable,
}

/// The answer to a GET (`get`) or HEAD of the file `version`.
pub fn answer(asked: &Conditions, get: bool, version: &Version) -> Answer {
    if let Some(tags) = asked.if_match {
        if !any_tag(tags, |t| strong_match(t, version.etag)) {
            return Answer::PreconditionFailed;
        }
    } else if let Some(date) = asked.if_unmodified_since.and_then(date)
        && version.modified > date
    {
        return Answer::PreconditionFailed;
    }
    if let Some(tags) = asked.if_none_match {
        if any_tag(tags, |t| weak_match(t, version.etag)) {
            return Answer::NotModified;
        }
    } else if let Some(date) = asked.if_modified_since.and_then(date)
        && version.modified <= date
    {
        return Answer::NotModified;
    }
    // Range is defined for GET only; HEAD describes the whole file.
    let Some(range) = asked.range.filter(|_| get) else {
        return Answer::Whole;
    };
    if let Some(validator) = asked.if_range
        && !if_range_matches(validator.trim(), version)
    {
        return Answer::Whole;
    }
    match parse_range(range) {
        Some(spec) => spec.resolve(version.len),
        None => Answer::Whole,
    }
}

/// Whether the list `tags` (or `*`) holds a tag accepted by `accept`.
fn any_tag(tags: &str, accept: impl Fn(&str) -> bool) -> bool {
    tags.trim() == "*" || tags.split(',').map(str::trim).any(accept)
}

fn strong_match(tag: &str, ours: &str) -> bool {
    !tag.starts_with("W/") && tag == ours
}

fn weak_match(tag: &str, ours: &str) -> bool {
    tag.trim_start_matches("W/") == ours.trim_start_matches("W/")
}

/// An entity tag must match strongly; a date must be the file's own.
fn if_range_matches(validator: &str, version: &Version) -> bool {
    if validator.starts_with('"') || validator.starts_with("W/") {
        strong_match(validator, version.etag)
    } else {
        date(validator) == Some(version.modified)
    }
}

fn date(value: &str) -> Option<SystemTime> {
    httpdate::parse_http_date(value.trim()).ok()
}

/// One byte range as asked, before the file's length is known.
#[derive(Debug, PartialEq, Eq)]
enum RangeSpec {
    /// `bytes=first-` or `bytes=first-last`.
    From { first: u64, last: Option<u64> },
    /// `bytes=-n`: the last n bytes.
    Suffix(u64),
}

/// A single byte range, or `None` for anything else.
fn parse_range(value: &str) -> Option<RangeSpec> {
    let (unit, set) = value.trim().split_once('=')?;
    if !unit.trim().eq_ignore_ascii_case("bytes") || set.contains(',') {
        return None;
    }
    let (first, last) = set.trim().split_once('-')?;
    let (first, last) = (first.trim(), last.trim());
    if first.is_empty() {
        return Some(RangeSpec::Suffix(number(last)?));
    }
    let first = number(first)?;
    let last = if last.is_empty() {
        None
    } else {
        Some(number(last)?).filter(|&l| l >= first)
    };
    if last.is_none() && !set.trim().ends_with('-') {
        return None;
    }
    Some(RangeSpec::From { first, last })
}

/// Decimal digits, saturating: a position past any file is still one.
fn number(digits: &str) -> Option<u64> {
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some(digits.bytes().fold(0u64, |n, b| {
        n.saturating_mul(10).saturating_add(u64::from(b - b'0'))
    }))
}

impl RangeSpec {
    fn resolve(&self, len: u64) -> Answer {
        match *self {
            RangeSpec::From { first, last } if first < len => Answer::Part {
                start: first,
                end: last.map_or(len - 1, |l| l.min(len - 1)),
            },
            RangeSpec::Suffix(n) if n > 0 && len > 0 => Answer::Part {
                start: len.saturating_sub(n),
                end: len - 1,
            },
            _ => Answer::Unsatisfiable,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, UNIX_EPOCH};

    const TAG: &str = "\"1-2-3.4\"";

    fn version() -> Version<'static> {
        Version {
            etag: TAG,
            modified: UNIX_EPOCH + Duration::from_secs(1_700_000_000),
            len: 100,
        }
    }

    fn get(asked: Conditions) -> Answer {
        answer(&asked, true, &version())
    }

    /// The answer to a GET with the one header `name`.
    fn one(name: &str, value: &str) -> Answer {
        let mut asked = Conditions::default();
        let field = match name {
            "If-Match" => &mut asked.if_match,
            "If-None-Match" => &mut asked.if_none_match,
            "If-Modified-Since" => &mut asked.if_modified_since,
            "If-Unmodified-Since" => &mut asked.if_unmodified_since,
            "Range" => &mut asked.range,
            _ => unreachable!("{name}"),
        };
        *field = Some(value);
        get(asked)
    }

    fn range(value: &str) -> Answer {
        one("Range", value)
    }

    #[test]
    fn single_ranges() {
        let part = |start, end| Answer::Part { start, end };
        assert_eq!(range("bytes=0-9"), part(0, 9));
        assert_eq!(range("bytes=10-"), part(10, 99));
        assert_eq!(range("bytes=-30"), part(70, 99));
        assert_eq!(range("bytes=-300"), part(0, 99));
        assert_eq!(range("bytes=90-1000"), part(90, 99));
        assert_eq!(range("BYTES = 5 - 5"), part(5, 5));
        assert_eq!(
            range("bytes=99999999999999999999999-"),
            Answer::Unsatisfiable
        );
        assert_eq!(range("bytes=100-"), Answer::Unsatisfiable);
        assert_eq!(range("bytes=-0"), Answer::Unsatisfiable);
        // Not one byte range: the whole file.
        for whole in [
            "bytes=0-1,5-6",
            "bytes=5-1",
            "items=0-1",
            "bytes=",
            "bytes=-",
            "bytes=a-b",
            "0-5",
            "bytes=1-2-3",
        ] {
            assert_eq!(range(whole), Answer::Whole, "{whole}");
        }
        // HEAD ignores Range.
        let asked = Conditions {
            range: Some("bytes=0-9"),
            ..Conditions::default()
        };
        assert_eq!(answer(&asked, false, &version()), Answer::Whole);
        // Nothing of an empty file can be asked for.
        let empty = Version {
            len: 0,
            ..version()
        };
        assert_eq!(answer(&asked, true, &empty), Answer::Unsatisfiable);
    }

    #[test]
    fn preconditions_in_order() {
        let at = |secs: u64| httpdate::fmt_http_date(UNIX_EPOCH + Duration::from_secs(secs));
        let (now, before) = (at(1_700_000_000), at(1_600_000_000));
        let none_match = |tags: &str| one("If-None-Match", tags);
        assert_eq!(none_match(TAG), Answer::NotModified);
        assert_eq!(none_match(&format!("\"x\", W/{TAG}")), Answer::NotModified);
        assert_eq!(none_match("*"), Answer::NotModified);
        assert_eq!(none_match("\"other\""), Answer::Whole);
        let modified_since = |date: &str| one("If-Modified-Since", date);
        assert_eq!(modified_since(&now), Answer::NotModified);
        assert_eq!(modified_since(&before), Answer::Whole);
        assert_eq!(modified_since("yesterday"), Answer::Whole);
        // If-None-Match wins over If-Modified-Since.
        let both = Conditions {
            if_none_match: Some("\"other\""),
            if_modified_since: Some(&now),
            ..Conditions::default()
        };
        assert_eq!(get(both), Answer::Whole);
        assert_eq!(one("If-Match", TAG), Answer::Whole);
        assert_eq!(
            one("If-Match", &format!("W/{TAG}")),
            Answer::PreconditionFailed
        );
        assert_eq!(
            one("If-Unmodified-Since", &before),
            Answer::PreconditionFailed
        );
        assert_eq!(one("If-Unmodified-Since", &now), Answer::Whole);
    }

    #[test]
    fn if_range_falls_back_to_the_whole_file() {
        let resume = |validator: &str| {
            get(Conditions {
                range: Some("bytes=50-"),
                if_range: Some(validator),
                ..Conditions::default()
            })
        };
        let part = Answer::Part { start: 50, end: 99 };
        assert_eq!(resume(TAG), part);
        assert_eq!(resume(&httpdate::fmt_http_date(version().modified)), part);
        assert_eq!(resume("\"changed\""), Answer::Whole);
        assert_eq!(resume(&format!("W/{TAG}")), Answer::Whole);
        assert_eq!(resume("Sun, 06 Nov 1994 08:49:37 GMT"), Answer::Whole);
    }
}
