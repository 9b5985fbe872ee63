//! The study's tables: per rope length, plant, profile and hoist, the median and the
//! worst of each measure over the cases of a row, and every case as a line.

use crate::study::{Measured, Outcome};

/// The median and the largest of `v` (sorted in place); `None` for none.
fn median_max(v: &mut [f64]) -> Option<(f64, f64)> {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let median = match n {
        0 => return None,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    };
    Some((median, v[n - 1]))
}

/// "median / worst" of what `f` takes from the measured outcomes, scaled; "—" where no
/// run was measured (every run faulted): no number where the study produced none.
fn median_worst(m: &[Measured], f: impl Fn(&Measured) -> f64, scale: f64, digits: usize) -> String {
    let mut v: Vec<f64> = m.iter().map(|m| f(m) * scale).collect();
    match median_max(&mut v) {
        Some((med, worst)) => format!("{med:.digits$} / {worst:.digits$}"),
        None => "—".to_string(),
    }
}

/// The table's header.
const HEADER: &str = "| crane | {key} | runs | faults | targets met | load error, mm, median / worst | swing, °, median / worst | correction travel, mm, median / worst | ∫\\|u − u_d\\| dt, mm, median / worst |\n|---|---|---:|---:|---:|---:|---:|---:|---:|";

/// One row over `outcomes`.
fn row(crane: &str, key: &str, outcomes: &[&Outcome]) -> String {
    let measured: Vec<Measured> = outcomes
        .iter()
        .filter_map(|o| o.result.as_ref().ok().copied())
        .collect();
    let faults = outcomes.len() - measured.len();
    let met = measured.iter().filter(|m| m.meets_targets()).count();
    format!(
        "| {crane} | {key} | {} | {faults} | {met} | {} | {} | {} | {} |",
        outcomes.len(),
        median_worst(&measured, |m| m.load_error, 1000.0, 1),
        median_worst(&measured, |m| m.swing, 1.0, 3),
        median_worst(&measured, |m| m.correction, 1000.0, 1),
        median_worst(&measured, |m| m.correction_total, 1000.0, 1),
    )
}

/// The table with a row per crane and value of `key` (named `title`), in the order the
/// outcomes first have them: each row over every case with that crane and value.
fn table(outcomes: &[Outcome], title: &str, key: impl Fn(&Outcome) -> String) -> String {
    let mut rows: Vec<(&str, String)> = Vec::new();
    for o in outcomes {
        let k = (o.crane, key(o));
        if !rows.contains(&k) {
            rows.push(k);
        }
    }
    let mut out = HEADER.replace("{key}", title) + "\n";
    for (crane, k) in &rows {
        let of: Vec<&Outcome> = outcomes
            .iter()
            .filter(|o| o.crane == *crane && key(o) == *k)
            .collect();
        out += &row(crane, k, &of);
        out += "\n";
    }
    out
}

/// The table per rope length.
#[must_use]
pub fn by_rope(outcomes: &[Outcome]) -> String {
    table(outcomes, "rope before the travel, m", |o| {
        format!("{}", o.rope)
    })
}

/// The table per plant.
#[must_use]
pub fn by_plant(outcomes: &[Outcome]) -> String {
    table(outcomes, "plant", |o| o.plant.to_string())
}

/// Per plant, the correction travel beside where the drives themselves went: the
/// largest distance of a plant's drive from a drive like the model's under `u_d`.
#[must_use]
pub fn drive_paths(outcomes: &[Outcome]) -> String {
    let mut rows: Vec<(&str, &str)> = Vec::new();
    for o in outcomes {
        if !rows.contains(&(o.crane, o.plant)) {
            rows.push((o.crane, o.plant));
        }
    }
    let mut out = String::from(
        "| crane | plant | runs measured | correction travel, mm, median / worst | drive off the model's, mm, median / worst |\n|---|---|---:|---:|---:|\n",
    );
    for (crane, plant) in rows {
        let measured: Vec<Measured> = outcomes
            .iter()
            .filter(|o| o.crane == crane && o.plant == plant)
            .filter_map(|o| o.result.as_ref().ok().copied())
            .collect();
        out += &format!(
            "| {crane} | {plant} | {} | {} | {} |\n",
            measured.len(),
            median_worst(&measured, |m| m.correction, 1000.0, 1),
            median_worst(&measured, |m| m.drive_offset, 1000.0, 1),
        );
    }
    out
}

/// The table per stick profile.
#[must_use]
pub fn by_profile(outcomes: &[Outcome]) -> String {
    table(outcomes, "profile", |o| o.profile.name())
}

/// The table per hoist lever.
#[must_use]
pub fn by_hoist(outcomes: &[Outcome]) -> String {
    table(outcomes, "hoist", |o| o.hoist.name().to_string())
}

/// Every case as a line, for the record (and the faults' messages).
#[must_use]
pub fn case_lines(outcomes: &[Outcome]) -> String {
    let mut out = String::from(
        "| crane | plant | profile | rope, m | hoist | rope at rest, m | pendulum, m | rest after release, s | load error, mm | swing, ° | correction travel, mm | ∫\\|u − u_d\\| dt, mm | swing in the first period after rest, ° |\n|---|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for o in outcomes {
        let hoist = o.hoist.name();
        match &o.result {
            Ok(m) => {
                out += &format!(
                    "| {} | {} | {} | {} | {hoist} | {:.2} | {:.2} | {:.2} | {:.1} | {:.3} | {:.1} | {:.1} | {:.3} |\n",
                    o.crane,
                    o.plant,
                    o.profile.name(),
                    o.rope,
                    m.rope_at_rest,
                    m.pendulum,
                    m.rest_after,
                    m.load_error * 1000.0,
                    m.swing,
                    m.correction * 1000.0,
                    m.correction_total * 1000.0,
                    m.swing_first
                );
            }
            Err(e) => {
                out += &format!(
                    "| {} | {} | {} | {} | {hoist} | {e} | | | | | | | |\n",
                    o.crane,
                    o.plant,
                    o.profile.name(),
                    o.rope
                );
            }
        }
    }
    out
}
