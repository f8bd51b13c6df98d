//! The inputs: real scene files mutated (bytes, lines, numbers), random lines and bytes.

use proptest::prelude::*;

/// Numbers that stress parsers and range checks.
const NUMBERS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "infinity",
    "1e39",
    "-1e39",
    "3.4028236e38",
    "3e38",
    "1e300",
    "-1e300",
    "1e-300",
    "1e-45",
    "0",
    "-0",
    "-1",
    "1",
    "2",
    "0.5",
    "0.99999994",
    "1.0",
    "1e5",
    "1e9",
    "1e18",
    "999999999999",
    "99999999999999999999",
    "-9223372036854775808",
    "9223372036854775807",
    "18446744073709551616",
    "4294967296",
    "2147483648",
    "0x10",
    "1_0",
    "+1",
    ".5",
    "5.",
    "1e",
    "e5",
    "",
    "-",
    "٣",
];

/// One mutation of a text file.
#[derive(Debug, Clone)]
pub(super) enum Op {
    FlipByte(usize, u8),
    InsertBytes(usize, Vec<u8>),
    DeleteRange(usize, usize),
    Number(usize, usize),
    DuplicateLine(usize),
    DeleteLine(usize),
    SwapLines(usize, usize),
    InsertLine(usize, usize),
    Truncate(usize),
}

pub(super) fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(p, m)| Op::FlipByte(p, m)),
        (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(p, b)| Op::InsertBytes(p, b)),
        (any::<usize>(), 1usize..16).prop_map(|(p, n)| Op::DeleteRange(p, n)),
        (any::<usize>(), any::<usize>()).prop_map(|(k, v)| Op::Number(k, v)),
        (any::<usize>(), any::<usize>()).prop_map(|(k, v)| Op::Number(k, v)),
        (any::<usize>(), any::<usize>()).prop_map(|(k, v)| Op::Number(k, v)),
        any::<usize>().prop_map(Op::DuplicateLine),
        any::<usize>().prop_map(Op::DeleteLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Op::SwapLines(a, b)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Op::InsertLine(a, b)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Op::InsertLine(a, b)),
        any::<usize>().prop_map(Op::Truncate),
    ]
}

/// Byte ranges of number-like tokens (digits with signs, dots and exponents).
fn number_spans(b: &[u8]) -> Vec<(usize, usize)> {
    let is_num = |c: u8| c.is_ascii_digit() || matches!(c, b'.' | b'-' | b'+' | b'e' | b'E');
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if is_num(b[i]) {
            let s = i;
            while i < b.len() && is_num(b[i]) {
                i += 1;
            }
            if b[s..i].iter().any(u8::is_ascii_digit) {
                out.push((s, i));
            }
        } else {
            i += 1;
        }
    }
    out
}

pub(super) fn apply(mut b: Vec<u8>, ops: &[Op], lines: &[&str]) -> Vec<u8> {
    for op in ops {
        match op {
            Op::FlipByte(p, m) if !b.is_empty() => {
                let k = p % b.len();
                b[k] ^= m.max(&1);
            }
            Op::InsertBytes(p, bytes) => {
                let k = p % (b.len() + 1);
                b.splice(k..k, bytes.iter().copied());
            }
            Op::DeleteRange(p, n) if !b.is_empty() => {
                let k = p % b.len();
                let e = (k + n).min(b.len());
                b.drain(k..e);
            }
            Op::Number(k, v) => {
                let spans = number_spans(&b);
                if !spans.is_empty() {
                    let (s, e) = spans[k % spans.len()];
                    b.splice(s..e, NUMBERS[v % NUMBERS.len()].bytes());
                }
            }
            Op::DuplicateLine(k)
            | Op::DeleteLine(k)
            | Op::SwapLines(k, _)
            | Op::InsertLine(k, _) => {
                let mut ls: Vec<Vec<u8>> = b.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect();
                let i = k % ls.len();
                match op {
                    Op::DuplicateLine(_) => {
                        let l = ls[i].clone();
                        ls.insert(i, l);
                    }
                    Op::DeleteLine(_) => {
                        ls.remove(i);
                    }
                    Op::SwapLines(_, j) => {
                        let j = j % ls.len();
                        ls.swap(i, j);
                    }
                    Op::InsertLine(_, w) => {
                        ls.insert(i, lines[w % lines.len()].as_bytes().to_vec())
                    }
                    _ => {}
                }
                b = ls.join(&b'\n');
            }
            Op::Truncate(p) if !b.is_empty() => {
                let k = p % b.len();
                b.truncate(k);
            }
            _ => {}
        }
    }
    b
}

/// A mutated seed, or random lines from the format's vocabulary, or random bytes.
pub(super) fn input(
    seeds: Vec<Vec<u8>>,
    lines: &'static [&'static str],
) -> impl Strategy<Value = Vec<u8>> {
    let n = seeds.len();
    prop_oneof![
        6 => (0..n, proptest::collection::vec(op(), 1..6))
            .prop_map(move |(i, ops)| apply(seeds[i].clone(), &ops, lines)),
        2 => proptest::collection::vec((0..lines.len(), 0..NUMBERS.len(), any::<bool>()), 0..40)
            .prop_map(move |ls| {
                ls.iter()
                    .map(|&(l, n, sub)| {
                        if sub {
                            String::from_utf8_lossy(&apply(
                                lines[l].as_bytes().to_vec(),
                                &[Op::Number(n, n)],
                                lines,
                            ))
                            .into_owned()
                        } else {
                            lines[l].to_string()
                        }
                    })
                    .collect::<Vec<_>>()
                    .join("\n")
                    .into_bytes()
            }),
        1 => proptest::collection::vec(any::<u8>(), 0..400),
    ]
}
