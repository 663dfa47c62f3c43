//! Text mutations for the property-based fuzz tests of Atrium's parsers (URDF, world,
//! scenario, sweep, error-map CSV). A test names its valid base text and the tokens and
//! numbers worth splicing in; [`mutation`] draws edits, [`apply`] makes them. Inputs that once
//! failed are kept in each test as explicit regression cases, so [`config`] keeps no
//! regression files.

use proptest::prelude::*;
use proptest::sample::{select, Index};

/// One edit of a text. Positions are [`Index`]es, scaled to the text's length when applied.
#[derive(Debug, Clone)]
pub enum Mutation {
    /// Removes up to `n` bytes.
    Delete(Index, usize),
    /// Inserts a token.
    Insert(Index, &'static str),
    /// Repeats the next `n` bytes.
    Duplicate(Index, usize),
    /// Replaces one of the numbers found by the test's span finder.
    Number(Index, String),
}

/// Numbers that break parsers and the arithmetic behind them, in the spelling TOML, XML and
/// CSV readers accept (or almost accept).
pub const HOSTILE_NUMBERS: &[&str] = &[
    "0",
    "0.0",
    "-0.0",
    "-1",
    "-1.0",
    "1",
    "1e300",
    "-1e300",
    "1e-300",
    "5e-324",
    "1.7976931348623157e308",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e",
    "4294967296",
    "18446744073709551616",
    "-9223372036854775809",
    "1e-9",
];

/// Edits drawn from `tokens` (inserted anywhere) and `numbers` (replacing a number), plus
/// deletions, duplications and arbitrary f64s.
pub fn mutation(
    tokens: &'static [&'static str],
    numbers: &'static [&'static str],
) -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<Index>(), 1usize..40).prop_map(|(i, n)| Mutation::Delete(i, n)),
        (any::<Index>(), select(tokens)).prop_map(|(i, t)| Mutation::Insert(i, t)),
        (any::<Index>(), 1usize..300).prop_map(|(i, n)| Mutation::Duplicate(i, n)),
        (any::<Index>(), select(numbers)).prop_map(|(i, v)| Mutation::Number(i, v.into())),
        (any::<Index>(), any::<f64>()).prop_map(|(i, v)| Mutation::Number(i, format!("{v:?}"))),
    ]
}

/// The previous char boundary at or before `at`.
fn floor_boundary(s: &str, mut at: usize) -> usize {
    at = at.min(s.len());
    while !s.is_char_boundary(at) {
        at -= 1;
    }
    at
}

/// `text` after `mutations`; `number_spans` finds the byte ranges of its numbers
/// ([`toml_number_spans`], [`xml_number_spans`], [`csv_number_spans`]).
pub fn apply(
    text: &str,
    mutations: &[Mutation],
    number_spans: fn(&str) -> Vec<(usize, usize)>,
) -> String {
    let mut s = text.to_string();
    for m in mutations {
        let at = |i: &Index, s: &str| floor_boundary(s, i.index(s.len() + 1));
        match m {
            Mutation::Delete(i, n) => {
                let a = at(i, &s);
                let b = floor_boundary(&s, a + n);
                s.replace_range(a..b, "");
            }
            Mutation::Insert(i, t) => {
                let a = at(i, &s);
                s.insert_str(a, t);
            }
            Mutation::Duplicate(i, n) => {
                let a = at(i, &s);
                let b = floor_boundary(&s, a + n);
                let piece = s[a..b].to_string();
                s.insert_str(b, &piece);
            }
            Mutation::Number(i, v) => {
                let spans = number_spans(&s);
                if !spans.is_empty() {
                    let (a, b) = spans[i.index(spans.len())];
                    s.replace_range(a..b, v);
                }
            }
        }
    }
    s
}

/// Numbers of a TOML text: a run of number characters starting with a digit or `-` after a
/// space, `[`, `,` or `=`, outside double-quoted strings (roughly).
pub fn toml_number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    let mut in_string = false;
    while i < b.len() {
        let c = b[i];
        if c == b'"' {
            in_string = !in_string;
            i += 1;
            continue;
        }
        let boundary = i == 0 || b" [,=".contains(&b[i - 1]);
        if !in_string && boundary && (c.is_ascii_digit() || c == b'-') {
            let mut j = i;
            while j < b.len() && (b[j].is_ascii_alphanumeric() || b"-.+_".contains(&b[j])) {
                j += 1;
            }
            spans.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    spans
}

/// Numbers of an XML text: inside attribute values, separated by quotes or spaces.
pub fn xml_number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts_number = (b[i].is_ascii_digit() || b[i] == b'-')
            && i > 0
            && (b[i - 1] == b'"' || b[i - 1] == b' ');
        if starts_number {
            let mut j = i;
            while j < b.len() && (b[j].is_ascii_alphanumeric() || b"-.+".contains(&b[j])) {
                j += 1;
            }
            if j < b.len() && (b[j] == b'"' || b[j] == b' ') {
                spans.push((i, j));
            }
            i = j.max(i + 1);
        } else {
            i += 1;
        }
    }
    spans
}

/// Numbers of a CSV text: whole fields that start with a digit, `-` or `+`.
pub fn csv_number_spans(text: &str) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = 0;
    for (i, c) in text
        .char_indices()
        .chain(std::iter::once((text.len(), '\n')))
    {
        if c == ',' || c == '\n' {
            let field = &text[start..i];
            if field
                .bytes()
                .next()
                .is_some_and(|b| b.is_ascii_digit() || b == b'-' || b == b'+')
            {
                spans.push((start, i));
            }
            start = i + 1;
        }
    }
    spans
}

/// `cases` cases (a fuzz test runs in about a second in CI) and no regression files.
pub fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_spans_find_the_numbers() {
        let t = "a = 1.5\nb = [2, -3e4]\nc = \"4\"";
        let found: Vec<&str> = toml_number_spans(t)
            .iter()
            .map(|&(a, b)| &t[a..b])
            .collect();
        assert_eq!(found, ["1.5", "2", "-3e4"]);
        let x = r#"<o xyz="1 -2.5 3"/>"#;
        let found: Vec<&str> = xml_number_spans(x).iter().map(|&(a, b)| &x[a..b]).collect();
        assert_eq!(found, ["1", "-2.5", "3"]);
        let c = "x,y\n1.0,-2\nab,+3";
        let found: Vec<&str> = csv_number_spans(c).iter().map(|&(a, b)| &c[a..b]).collect();
        assert_eq!(found, ["1.0", "-2", "+3"]);
    }

    proptest! {
        #![proptest_config(config(256))]

        #[test]
        fn edits_respect_char_boundaries(
            mutations in prop::collection::vec(mutation(&["é", "\u{feff}"], HOSTILE_NUMBERS), 1..8)
        ) {
            // `apply` panics on a split character; it must not.
            let out = apply("é = 1\nü = [2, 3]\n", &mutations, toml_number_spans);
            prop_assert!(out.len() < 10_000);
        }
    }
}
