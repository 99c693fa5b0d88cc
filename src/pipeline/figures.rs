//! What a figure shows per sub-group: the augmented conditions a sub-group adds to the
//! previous one (rotations, then scalings, then the reflection), evenly strided, with a
//! caption naming the set and the ranges of `θ` (degrees) and `λ`; and a file's name for a
//! figure's title ([`file_name`]).

use crate::symmetry::compose::Condition;

/// Up to `max` augmented trajectories of demonstration `demo` that sub-group
/// `SubGroup::ALL[gi]` adds to the previous one (rotations, then scalings, then the
/// reflection; all of it for the first), evenly strided, and a caption naming the set and
/// the ranges of `θ` and `λ` shown.
pub fn figure_conditions(
    set: &crate::data::augmentation::AugmentedSet,
    gi: usize,
    demo: Option<usize>,
    max: usize,
) -> (Vec<&crate::data::augmentation::Augmented>, String) {
    use crate::policy::SubGroup;
    let g = SubGroup::ALL[gi];
    let all: Vec<_> = set
        .subset(g)
        .into_iter()
        .filter(|a| Some(a.traj.demo) == demo)
        .collect();
    let new: Vec<_> = match gi.checked_sub(1) {
        Some(prev) => all
            .iter()
            .copied()
            .filter(|a| !SubGroup::ALL[prev].contains(&a.condition))
            .collect(),
        None => all.clone(),
    };
    let sel = if new.is_empty() { all } else { new };
    let stride = sel.len().div_ceil(max.max(1)).max(1);
    let shown: Vec<_> = sel.into_iter().step_by(stride).collect();
    let range = |f: &dyn Fn(&Condition) -> f64, unit: &str| {
        let (lo, hi) = shown
            .iter()
            .map(|a| f(&a.condition))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        let r = crate::eval::plot::signed;
        if hi - lo < 1e-9 {
            format!("{}{unit}", r(lo))
        } else {
            format!("{}…{}{unit}", r(lo), r(hi))
        }
    };
    let mut label = format!(
        "{}: {} condition{}, θ {}, λ {}",
        g.label(),
        shown.len(),
        if shown.len() == 1 { "" } else { "s" },
        range(&|c| c.theta.to_degrees(), "°"),
        range(&|c| c.scale, "")
    );
    if shown.iter().any(|a| a.condition.reflection < 0) {
        label.push_str(", σ = −1");
    }
    (shown, label)
}

/// A file's name for a figure title (the whole path when it has none).
pub fn file_name(p: &std::path::Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    )
}
