//! Which axis of a stored array is time, which are the cube's rows and columns, and what
//! becomes of the others: the decision ([`decide`]) and its application ([`Layout::apply`]).
//!
//! Axes are numbered as the file stores them, the shape `femto info` prints (MATLAB's
//! order for `.mat`). The rules, in order:
//!
//! 1. Singleton axes (length 1) are dropped.
//! 2. Time is the axis `--time-axis N` names; else the one the file names (a HyperSpy axis
//!    with time units, a dimension label `T`, a bin count key); else, with `--transpose`,
//!    the one before the last; else the last. A guess (the last, or the one before it) stands
//!    only when no other axis is at least [`AMBIGUOUS_RATIO`] times longer: a time-first
//!    `(512, 32, 32)` scan is refused in one line naming its shape and `--time-axis`, never
//!    read with a spatial axis as time.
//! 3. Axes the file names as extra (channels, wavelengths, frames, z) are summed, or one
//!    index is kept with `--select NAME=I`; unnamed ones become rows and columns in their
//!    order (one left: a single scanline), and more than two are refused unless
//!    `--sum N` or `--select N=I` says what to do with the rest.
//!
//! The decision is kept in words ([`Layout::describe`]) for the cube's provenance.

use super::array::Array;
use super::{Axis, ReaderError, TimeSpec};
use std::path::Path;

/// What a format's reader found, before the layout is decided.
pub(super) struct Stored {
    /// Which dataset, variable or signal, as the user would name it.
    pub source: String,
    pub array: Array,
    /// What the file says of each stored axis (empty: nothing).
    pub axes: Vec<AxisInfo>,
    /// The spatial calibration of each stored axis, where the file records one.
    pub scales: Vec<Option<Axis>>,
    /// The time axis the file records (of the axis whose role is time, or of whichever
    /// axis becomes time when the file names none).
    pub time: TimeSpec,
    pub time_source: String,
    pub attributes: Vec<(String, String)>,
}

/// Another axis at least this many times longer than the last one makes "time is last" a
/// guess: the layout is refused unless `--time-axis` names time. Measured cases: the
/// time-first confocal scans of issue 44 are 16 times longer (512 bins, 32 x 32 grid);
/// x-y-t cubes read so far have time the longest axis (2048 bins on 64 x 64).
pub const AMBIGUOUS_RATIO: usize = 2;

/// What the file says one stored axis is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Time,
    Y,
    X,
    /// Neither time nor space: channels, wavelengths, frames, z.
    Extra,
}

/// One stored axis as the file describes it: its name (empty when it has none) and role
/// (`None`: the file does not say).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AxisInfo {
    pub name: String,
    pub role: Option<Role>,
}

impl AxisInfo {
    /// An axis with a name and a role.
    pub fn named(name: &str, role: Role) -> AxisInfo {
        AxisInfo {
            name: name.to_string(),
            role: Some(role),
        }
    }
}

/// An axis as the user names it: by its number in the stored shape, or by its name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AxisRef {
    Index(usize),
    Name(String),
}

impl AxisRef {
    /// `3` is an index, anything else a name.
    pub fn parse(text: &str) -> AxisRef {
        match text.trim().parse::<usize>() {
            Ok(i) => AxisRef::Index(i),
            Err(_) => AxisRef::Name(text.trim().to_string()),
        }
    }
}

impl std::fmt::Display for AxisRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AxisRef::Index(i) => write!(f, "{i}"),
            AxisRef::Name(n) => f.write_str(n),
        }
    }
}

/// What becomes of an extra axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduce {
    Sum,
    Select(usize),
}

/// The user's say in the layout: `--time-axis`, `--transpose`, `--select`, `--sum`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LayoutOptions {
    pub time_axis: Option<usize>,
    /// The time axis is the one before the last (a `(t, x)` image, a `(y, t, x)` stack).
    pub transpose: bool,
    /// Keep one index of these axes.
    pub select: Vec<(AxisRef, usize)>,
    /// Sum these axes.
    pub sum: Vec<AxisRef>,
}

impl LayoutOptions {
    /// Whether the user said anything about the layout.
    pub fn is_empty(&self) -> bool {
        self.time_axis.is_none() && !self.transpose && self.select.is_empty() && self.sum.is_empty()
    }
}

/// The decision: which stored axis is time, rows and columns, and what the others become.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub shape: Vec<usize>,
    pub names: Vec<String>,
    pub t: usize,
    pub y: Option<usize>,
    pub x: Option<usize>,
    /// Every other axis longer than 1, with what becomes of it.
    pub extra: Vec<(usize, Reduce)>,
    /// How time was decided, in words.
    pub time_from: String,
}

fn label(names: &[String], i: usize) -> String {
    match names.get(i).filter(|n| !n.is_empty()) {
        Some(n) => format!("axis {i} ({n})"),
        None => format!("axis {i}"),
    }
}

impl Layout {
    /// `(ny, nx, nt)` of the cube.
    pub fn dims(&self) -> (usize, usize, usize) {
        let len = |d: Option<usize>| d.map_or(1, |d| self.shape[d]);
        (len(self.y), len(self.x), self.shape[self.t])
    }

    /// The decision in words, for provenance and `femto info`: `time: axis 0 of [512, 32,
    /// 32] (--time-axis 0); rows: axis 1 (32); columns: axis 2 (32)`.
    pub fn describe(&self) -> String {
        let n = |d: usize| self.shape[d];
        let mut parts = vec![format!(
            "time: {} of {:?} ({})",
            label(&self.names, self.t),
            self.shape,
            self.time_from
        )];
        match self.y {
            Some(d) => parts.push(format!("rows: {} ({})", label(&self.names, d), n(d))),
            None => parts.push("rows: 1".into()),
        }
        match self.x {
            Some(d) => parts.push(format!("columns: {} ({})", label(&self.names, d), n(d))),
            None => parts.push("columns: 1".into()),
        }
        for (d, r) in &self.extra {
            let what = match r {
                Reduce::Sum => "summed".to_string(),
                Reduce::Select(i) => format!("index {i} kept"),
            };
            parts.push(format!("{} ({}): {what}", label(&self.names, *d), n(*d)));
        }
        let singles: Vec<String> = (0..self.shape.len())
            .filter(|&d| self.shape[d] == 1)
            .map(|d| d.to_string())
            .collect();
        if !singles.is_empty() {
            parts.push(format!("singleton axes {} dropped", singles.join(", ")));
        }
        parts.join("; ")
    }

    /// The array's values as x-y-t samples `[y][x][t]`: extra axes summed or one index
    /// kept, singletons dropped, then rows, columns and time in that order.
    pub fn apply(&self, a: &Array) -> Vec<f32> {
        let mut shape = a.shape.clone();
        let mut values = std::borrow::Cow::Borrowed(&a.values);
        let mut extra = self.extra.clone();
        // Highest axis first, so that the lower axes keep their numbers.
        extra.sort_by_key(|e| std::cmp::Reverse(e.0));
        for (d, r) in extra {
            values = std::borrow::Cow::Owned(reduce(&shape, &values, d, r));
            shape[d] = 1;
        }
        let order: Vec<usize> = [self.y, self.x, Some(self.t)]
            .into_iter()
            .flatten()
            .collect();
        let kept: Vec<usize> = order.iter().map(|&d| shape[d]).collect();
        let rest: Vec<usize> = (0..shape.len()).filter(|d| !order.contains(d)).collect();
        // Every axis not in `order` has length 1 now; moving them first is free.
        let mut full: Vec<usize> = rest.clone();
        full.extend(&order);
        let in_order = full.windows(2).all(|w| w[0] < w[1]);
        let out = if in_order {
            values.into_owned()
        } else {
            super::array::permute(&shape, &values, &full)
        };
        debug_assert_eq!(out.len(), kept.iter().product::<usize>());
        out
    }
}

/// Sum axis `d` of the C-order array `values` of `shape`, or keep index `i` of it.
fn reduce(shape: &[usize], values: &[f32], d: usize, r: Reduce) -> Vec<f32> {
    let outer: usize = shape[..d].iter().product();
    let n = shape[d];
    let inner: usize = shape[d + 1..].iter().product();
    let mut out = vec![0f32; outer * inner];
    for o in 0..outer {
        let dst = &mut out[o * inner..(o + 1) * inner];
        match r {
            Reduce::Select(i) => {
                dst.copy_from_slice(&values[(o * n + i) * inner..(o * n + i + 1) * inner]);
            }
            Reduce::Sum => {
                let mut acc = vec![0f64; inner];
                for j in 0..n {
                    let src = &values[(o * n + j) * inner..(o * n + j + 1) * inner];
                    acc.iter_mut()
                        .zip(src)
                        .for_each(|(a, &v)| *a += f64::from(v));
                }
                dst.iter_mut().zip(&acc).for_each(|(v, &a)| *v = a as f32);
            }
        }
    }
    out
}

/// The stored axis `r` names among `names` (a number, or a name matched without case).
fn resolve(
    path: &Path,
    flag: &str,
    r: &AxisRef,
    shape: &[usize],
    names: &[String],
) -> Result<usize, ReaderError> {
    let bad = |m: String| ReaderError::choice(path, flag, m);
    match r {
        AxisRef::Index(i) if *i < shape.len() => Ok(*i),
        AxisRef::Index(i) => Err(bad(format!(
            "axis {i}: the array {shape:?} has axes 0 to {}",
            shape.len().saturating_sub(1)
        ))),
        AxisRef::Name(n) => names
            .iter()
            .position(|m| !m.is_empty() && m.eq_ignore_ascii_case(n))
            .ok_or_else(|| {
                let named: Vec<String> = names
                    .iter()
                    .enumerate()
                    .filter(|(_, m)| !m.is_empty())
                    .map(|(i, m)| format!("{i} {m}"))
                    .collect();
                bad(if named.is_empty() {
                    format!("no axis is named {n}; this array's axes have no names: give a number 0 to {}", shape.len().saturating_sub(1))
                } else {
                    format!("no axis is named {n}; the axes: {}", named.join(", "))
                })
            }),
    }
}

/// Decide the layout of an array of `shape` whose axes the file describes as `axes` (empty:
/// no names). `what` names the array in messages (`variable meas`).
pub fn decide(
    path: &Path,
    what: &str,
    shape: &[usize],
    axes: &[AxisInfo],
    opts: &LayoutOptions,
) -> Result<Layout, ReaderError> {
    let rank = shape.len();
    let info = |d: usize| axes.get(d).cloned().unwrap_or_default();
    let names: Vec<String> = (0..rank).map(|d| info(d).name).collect();
    let role = |d: usize| info(d).role;
    if shape.contains(&0) {
        return Err(ReaderError::invalid(
            path,
            "shape",
            format!("{what} {shape:?} holds no values"),
        ));
    }
    let long: Vec<usize> = (0..rank).filter(|&d| shape[d] > 1).collect();
    if long.is_empty() {
        return Err(ReaderError::invalid(
            path,
            "shape",
            format!("{what} {shape:?} holds one value, no time axis"),
        ));
    }
    let named_t = (0..rank).find(|&d| role(d) == Some(Role::Time));
    let t = time_axis(path, what, shape, &names, named_t, &long, opts)?;
    let time_from = match (opts.time_axis, named_t) {
        (Some(n), _) => format!("--time-axis {n}"),
        (None, Some(_)) => "named by the file".to_string(),
        (None, None) if opts.transpose => "--transpose: the one before the last".to_string(),
        (None, None) => "the last axis".to_string(),
    };
    let roles: Vec<Option<Role>> = (0..rank).map(role).collect();
    let reduce_of = reductions(path, shape, &names, &roles, t, opts)?;
    let mut y = long
        .iter()
        .copied()
        .find(|&d| d != t && role(d) == Some(Role::Y));
    let mut x = long
        .iter()
        .copied()
        .find(|&d| d != t && role(d) == Some(Role::X));
    let mut extra = Vec::new();
    let mut free = Vec::new();
    for &d in &long {
        if d == t || Some(d) == y || Some(d) == x {
            continue;
        }
        match (reduce_of[d], role(d)) {
            (Some(r), _) => extra.push((d, r)),
            (None, Some(Role::Extra | Role::Y | Role::X | Role::Time)) => {
                extra.push((d, Reduce::Sum))
            }
            (None, None) => free.push(d),
        }
    }
    let room = [y, x].iter().filter(|s| s.is_none()).count();
    if free.len() > room {
        return Err(ReaderError::choice(
            path,
            "shape",
            format!(
                "{what} {shape:?}: {} axes besides time ({}), femto reads rows and columns; say \
                 what the others are: --sum N or --select N=I (N indexes this shape)",
                free.len() + usize::from(y.is_some()) + usize::from(x.is_some()),
                label(&names, t)
            ),
        ));
    }
    // Unnamed axes fill the free places in order: rows, then columns (one left: columns).
    match (free.as_slice(), y, x) {
        ([a, b], None, None) => {
            y = Some(*a);
            x = Some(*b);
        }
        ([a], _, None) => x = Some(*a),
        ([a], None, Some(_)) => y = Some(*a),
        _ => {}
    }
    // Selected singleton axes: index 0 is the only one; nothing to do.
    Ok(Layout {
        shape: shape.to_vec(),
        names,
        t,
        y,
        x,
        extra,
        time_from,
    })
}

/// What `--select` and `--sum` do to each stored axis; refused for the time axis `t` and
/// for an axis the file names as a row or column.
fn reductions(
    path: &Path,
    shape: &[usize],
    names: &[String],
    roles: &[Option<Role>],
    t: usize,
    opts: &LayoutOptions,
) -> Result<Vec<Option<Reduce>>, ReaderError> {
    let rank = shape.len();
    let role = |d: usize| roles[d];
    let mut reduce_of: Vec<Option<Reduce>> = vec![None; rank];
    for (r, i) in &opts.select {
        let d = resolve(path, "--select", r, shape, names)?;
        if *i >= shape[d] {
            return Err(ReaderError::choice(
                path,
                "--select",
                format!(
                    "{r}={i}: {} has {} indices (0 to {})",
                    label(names, d),
                    shape[d],
                    shape[d] - 1
                ),
            ));
        }
        reduce_of[d] = Some(Reduce::Select(*i));
    }
    for r in &opts.sum {
        let d = resolve(path, "--sum", r, shape, names)?;
        reduce_of[d] = Some(Reduce::Sum);
    }
    if let Some(d) = (0..rank)
        .find(|&d| reduce_of[d].is_some() && (d == t || matches!(role(d), Some(Role::Y | Role::X))))
    {
        let flag = if matches!(reduce_of[d], Some(Reduce::Sum)) {
            "--sum"
        } else {
            "--select"
        };
        return Err(ReaderError::choice(
            path,
            flag,
            format!(
                "{} is {}, not an extra axis",
                label(names, d),
                if d == t { "time" } else { "a spatial axis" }
            ),
        ));
    }
    Ok(reduce_of)
}

/// The time axis (rule 2 of the module documentation).
fn time_axis(
    path: &Path,
    what: &str,
    shape: &[usize],
    names: &[String],
    named_t: Option<usize>,
    long: &[usize],
    opts: &LayoutOptions,
) -> Result<usize, ReaderError> {
    let rank = shape.len();
    if let Some(n) = opts.time_axis {
        if opts.transpose {
            return Err(ReaderError::choice(
                path,
                "--time-axis",
                "--transpose says the same thing less precisely; give one of them",
            ));
        }
        if n >= rank {
            return Err(ReaderError::choice(
                path,
                "--time-axis",
                format!("{n}: {what} {shape:?} has axes 0 to {}", rank - 1),
            ));
        }
        if shape[n] < 2 {
            return Err(ReaderError::choice(
                path,
                "--time-axis",
                format!("{n}: axis {n} of {what} {shape:?} has length {}", shape[n]),
            ));
        }
        if let Some(d) = named_t.filter(|&d| d != n) {
            return Err(ReaderError::choice(
                path,
                "--time-axis",
                format!(
                    "{n} contradicts the file, which names {} of {shape:?} as time; leave it out",
                    label(names, d)
                ),
            ));
        }
        return Ok(n);
    }
    if let Some(d) = named_t {
        if opts.transpose {
            return Err(ReaderError::choice(
                path,
                "--transpose",
                format!(
                    "{what} names its time axis ({}); leave out --transpose",
                    label(names, d)
                ),
            ));
        }
        if shape[d] < 2 {
            return Err(ReaderError::choice(
                path,
                "shape",
                format!(
                    "{what} {shape:?}: its time axis ({}) has one bin",
                    label(names, d)
                ),
            ));
        }
        return Ok(d);
    }
    let t = if opts.transpose {
        match long {
            [.., before, _] => *before,
            _ => {
                return Err(ReaderError::choice(
                    path,
                    "--transpose",
                    format!("{what} {shape:?} has one axis longer than 1"),
                ))
            }
        }
    } else {
        *long.last().expect("checked by the caller")
    };
    if let Some(&d) = long
        .iter()
        .find(|&&d| d != t && shape[d] >= AMBIGUOUS_RATIO * shape[t])
    {
        return Err(ReaderError::choice(
            path,
            "--time-axis",
            format!(
                "{what} {shape:?}: axis {d} ({}) is {:.0} times longer than axis {t} ({}), \
                 which {} takes for time, so which axis is time is not known; name it with \
                 --time-axis N (N indexes this shape: --time-axis {d} if axis {d} is time)",
                shape[d],
                shape[d] as f64 / shape[t] as f64,
                shape[t],
                if opts.transpose {
                    "--transpose"
                } else {
                    "the default (the last axis)"
                }
            ),
        ));
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::readers::Dtype;

    fn array(shape: &[usize]) -> Array {
        let n = shape.iter().product::<usize>();
        Array {
            shape: shape.to_vec(),
            dtype: Dtype::F32,
            values: (0..n).map(|i| i as f32).collect(),
            inexact: 0,
            largest_inexact: 0.0,
        }
    }

    fn p() -> &'static Path {
        Path::new("f")
    }

    /// The naive reference: element [y][x][t] by its full stored index.
    fn naive(shape: &[usize], t: usize, y: Option<usize>, x: Option<usize>, v: &[f32]) -> Vec<f32> {
        let idx = |coords: &[usize]| coords.iter().zip(shape).fold(0, |a, (c, n)| a * n + c);
        let len = |d: Option<usize>| d.map_or(1, |d| shape[d]);
        let mut out = Vec::new();
        for iy in 0..len(y) {
            for ix in 0..len(x) {
                for it in 0..shape[t] {
                    let mut c = vec![0; shape.len()];
                    c[t] = it;
                    if let Some(d) = y {
                        c[d] = iy;
                    }
                    if let Some(d) = x {
                        c[d] = ix;
                    }
                    out.push(v[idx(&c)]);
                }
            }
        }
        out
    }

    #[test]
    fn a_time_first_scan_is_refused_and_read_with_time_axis_0() {
        let shape = [16, 4, 4];
        let err = decide(p(), "variable meas", &shape, &[], &LayoutOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("--time-axis") && err.contains("[16, 4, 4]"),
            "{err}"
        );
        let opts = LayoutOptions {
            time_axis: Some(0),
            ..Default::default()
        };
        let l = decide(p(), "v", &shape, &[], &opts).unwrap();
        assert_eq!((l.t, l.y, l.x), (0, Some(1), Some(2)));
        assert_eq!(l.dims(), (4, 4, 16));
        let a = array(&shape);
        assert_eq!(l.apply(&a), naive(&shape, 0, Some(1), Some(2), &a.values));
        assert!(l.describe().contains("--time-axis 0"), "{}", l.describe());
    }

    #[test]
    fn time_last_when_unambiguous_singletons_dropped() {
        let shape = [1, 3, 1, 5];
        let l = decide(p(), "v", &shape, &[], &LayoutOptions::default()).unwrap();
        assert_eq!((l.t, l.y, l.x), (3, None, Some(1)));
        let a = array(&shape);
        assert_eq!(l.apply(&a), a.values);
        let one = decide(p(), "v", &[1, 65536], &[], &LayoutOptions::default()).unwrap();
        assert_eq!(one.dims(), (1, 1, 65536));
    }

    #[test]
    fn named_extra_axes_are_summed_or_selected() {
        // Delmic's (C, T, Z, Y, X).
        let shape = [3, 4, 1, 2, 5];
        let axes = [
            AxisInfo::named("C", Role::Extra),
            AxisInfo::named("T", Role::Time),
            AxisInfo::named("Z", Role::Extra),
            AxisInfo::named("Y", Role::Y),
            AxisInfo::named("X", Role::X),
        ];
        let a = array(&shape);
        let l = decide(p(), "Image", &shape, &axes, &LayoutOptions::default()).unwrap();
        assert_eq!(
            (l.t, l.y, l.x, l.extra.clone()),
            (1, Some(3), Some(4), vec![(0, Reduce::Sum)])
        );
        let got = l.apply(&a);
        // Sum over C by hand: element (c, t, 0, y, x) = ((c*4 + t)*2 + y)*5 + x.
        let want: Vec<f32> = (0..2)
            .flat_map(|y| {
                (0..5).flat_map(move |x| {
                    (0..4)
                        .map(move |t| (0..3).map(|c| (((c * 4 + t) * 2 + y) * 5 + x) as f32).sum())
                })
            })
            .collect();
        assert_eq!(got, want);
        let sel = LayoutOptions {
            select: vec![(AxisRef::Name("c".into()), 2)],
            ..Default::default()
        };
        let l = decide(p(), "Image", &shape, &axes, &sel).unwrap();
        let got = l.apply(&a);
        let want: Vec<f32> = (0..2)
            .flat_map(|y| {
                (0..5)
                    .flat_map(move |x| (0..4).map(move |t| (((2 * 4 + t) * 2 + y) * 5 + x) as f32))
            })
            .collect();
        assert_eq!(got, want);
        let bad = LayoutOptions {
            select: vec![(AxisRef::Name("C".into()), 3)],
            ..Default::default()
        };
        assert!(decide(p(), "Image", &shape, &axes, &bad).is_err());
        let t = LayoutOptions {
            time_axis: Some(0),
            ..Default::default()
        };
        assert!(decide(p(), "Image", &shape, &axes, &t)
            .unwrap_err()
            .to_string()
            .contains("contradicts"));
    }

    #[test]
    fn four_unnamed_axes_need_a_word_on_the_extra_one() {
        let shape = [2, 3, 4, 9];
        let err = decide(p(), "v", &shape, &[], &LayoutOptions::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("--sum") && err.contains("--select"), "{err}");
        let opts = LayoutOptions {
            sum: vec![AxisRef::Index(0)],
            ..Default::default()
        };
        let l = decide(p(), "v", &shape, &[], &opts).unwrap();
        assert_eq!((l.t, l.y, l.x), (3, Some(1), Some(2)));
        let a = array(&shape);
        let got = l.apply(&a);
        let want: Vec<f32> = naive(
            &[3, 4, 9],
            2,
            Some(0),
            Some(1),
            &(0..108).map(|i| (i + (i + 108)) as f32).collect::<Vec<_>>(),
        );
        assert_eq!(got, want);
    }

    #[test]
    fn transpose_takes_the_axis_before_the_last() {
        let shape = [3, 8, 5];
        let opts = LayoutOptions {
            transpose: true,
            ..Default::default()
        };
        let l = decide(p(), "v", &shape, &[], &opts).unwrap();
        assert_eq!((l.t, l.y, l.x), (1, Some(0), Some(2)));
        let a = array(&shape);
        assert_eq!(l.apply(&a), naive(&shape, 1, Some(0), Some(2), &a.values));
    }
}
