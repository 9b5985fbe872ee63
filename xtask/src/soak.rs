//! `cargo xtask soak --minutes M`: the QEMU firmware through M simulated minutes of
//! random valid and invalid requests, garbage and faults (`sim::traffic`), after
//! the default scene's move. Every frame is checked against the drive limits here,
//! independently of the controller's choke point, and against the host's run of the
//! same traffic.

use std::collections::BTreeMap;

use controller::canopen::{cob, emcy};
use controller::commands::STATUS_ID;
use controller::drive::PLANAR;
use controller::setpoint::{DriveLimits, UNITS_PER_M_PER_S};
use controller::Config;
use sim::{Scenario, SOAK};

use crate::firmware::parse_tx;
use crate::qemu;

/// What the soak run found.
#[derive(Debug, Default)]
struct Findings {
    set_points: u64,
    over_speed: u64,
    over_acceleration: u64,
    refused_non_finite: u64,
    refused_other: u64,
    deadline_misses: u64,
    worst: (u64, u64),
    answers: BTreeMap<String, u64>,
    faults: BTreeMap<u8, u64>,
}

/// Runs the soak and prints its report; fails on any violation or any difference
/// from the host.
pub fn soak(minutes: u32) -> Result<(), String> {
    let cycles = minutes
        .checked_mul(6_000)
        .filter(|c| *c > 0)
        .ok_or("--minutes must be between 1 and 715,000")?;
    let scenario = Scenario { cycles, ..SOAK };
    let started = std::time::Instant::now();
    let m = qemu::measure_scenario(qemu::SCENARIO_SCENE, scenario)?;
    let qemu_seconds = started.elapsed().as_secs();
    if !m.success {
        return Err("soak: the firmware did not exit with success".into());
    }
    if m.costs.len() != cycles as usize {
        return Err(format!("soak: {} cycles logged of {cycles}", m.costs.len()));
    }
    let f = findings(&m);
    let (_, mean, _) = m.cost_summary();
    println!("\nSoak: {minutes} simulated minutes of random traffic on the QEMU firmware ({}), {qemu_seconds} s of wall time", qemu::SCENARIO_SCENE);
    println!(
        "(`cargo xtask soak --minutes {minutes}`; traffic seed {:#x})\n",
        SOAK.random.unwrap_or(0)
    );
    println!("| measure | value |\n|---|---:|");
    println!("| steps (100 Hz cycles) | {cycles} |");
    println!("| set points sent | {} |", f.set_points);
    println!("| non-finite set points sent | 0 (frames carry integers; the choke point refused {} non-finite model outputs) |", f.refused_non_finite);
    println!("| set points above the velocity limit | {} |", f.over_speed);
    println!(
        "| set-point steps above the acceleration limit | {} |",
        f.over_acceleration
    );
    println!(
        "| model outputs refused at the choke point (over limit) | {} |",
        f.refused_other
    );
    println!(
        "| deadline misses (cycles over {} instructions) | {} |",
        Config::DEFAULT.cycle_budget(),
        f.deadline_misses
    );
    println!(
        "| worst instructions per step | {} (cycle {}) |",
        f.worst.0, f.worst.1
    );
    println!("| mean instructions per step | {mean} |");
    println!("| stack high-water mark | {} bytes |", m.stack);
    println!(
        "| … since the control task started | {} bytes |",
        m.task_stack
    );
    println!("\nAnswers: {}", list(&f.answers));
    println!(
        "Faults met (status fault code: times): {}",
        f.faults
            .iter()
            .map(|(k, v)| format!("{k}: {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    qemu::compare_with_host(&m)?;
    println!("QEMU sent exactly the frames the host computes for the same traffic.");
    let violations = f.over_speed + f.over_acceleration + f.refused_non_finite + f.refused_other;
    if violations > 0 {
        return Err(format!("soak: {violations} limit violations or refusals"));
    }
    Ok(())
}

fn list(m: &BTreeMap<String, u64>) -> String {
    m.iter()
        .map(|(k, v)| format!("{k} {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Reads the whole log: every RPDO against the limits, the EMCYs, the answers, the costs.
fn findings(m: &qemu::Measured) -> Findings {
    let limits = DriveLimits::LAB;
    let h = f64::from(Config::DEFAULT.period_ms) / 1000.0;
    let mut f = Findings::default();
    let mut last: [Option<i64>; 2] = [None, None];
    let mut last_answer = None;
    for tx in m.lines.iter().filter_map(|l| parse_tx(l)) {
        for (i, d) in PLANAR.into_iter().enumerate() {
            if tx.id == cob::RPDO1 + u16::from(d.node()) && tx.data.len() == 6 {
                let v = i64::from(i32::from_le_bytes([
                    tx.data[2], tx.data[3], tx.data[4], tx.data[5],
                ]));
                let l = limits.axes()[i];
                f.set_points += 1;
                if v.abs() as f64 > l.max_velocity * UNITS_PER_M_PER_S {
                    f.over_speed += 1;
                }
                if let Some(prev) = last[i] {
                    if (v - prev).abs() as f64 > l.max_acceleration * h * UNITS_PER_M_PER_S + 1.0 {
                        f.over_acceleration += 1;
                    }
                }
                last[i] = Some(v);
            }
        }
        // A fault's EMCY, by its fault byte; not 0x0000 (error reset) nor the abort code
        // that follows a commissioning failure (0xFF12, byte 16: no fault of its own).
        if tx.id == 0x090
            && tx.data.len() == 8
            && tx.data[0..2] != [0, 0]
            && u16::from_le_bytes([tx.data[0], tx.data[1]]) != emcy::COMMISSIONING_ABORT
        {
            *f.faults.entry(tx.data[3]).or_default() += 1;
            if tx.data[3] == 2 {
                if tx.data[5] == 1 {
                    f.refused_non_finite += 1;
                } else {
                    f.refused_other += 1;
                }
            }
        }
        if tx.id == STATUS_ID
            && tx.data.len() == 8
            && tx.data[1] != 0
            && last_answer != Some(tx.data[0])
        {
            last_answer = Some(tx.data[0]);
            let name = match (tx.data[1], tx.data[2]) {
                (1, _) => "accepted".to_string(),
                (2, _) => "queued".to_string(),
                (4, _) => "overload".to_string(),
                (_, r) => format!("rejected({r})"),
            };
            *f.answers.entry(name).or_default() += 1;
        }
    }
    for s in &m.steps {
        if s.instructions > Config::DEFAULT.cycle_budget() {
            f.deadline_misses += 1;
        }
        if s.instructions > f.worst.0 {
            f.worst = (s.instructions, u64::from(s.cycle));
        }
    }
    f
}
