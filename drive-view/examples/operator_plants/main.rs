//! The closed loop in manual mode on plants that are not the model, each error alone and
//! combined (issue 28): `cargo run -p drive-view --example operator_plants -- [--threads N]
//! [--ropes 3.5,8] [--cases]`. Prints the table per rope length and per plant (median and
//! worst of the load's error, the swing one swing period after rest and the feedback's
//! correction travel; `study.rs` says what each is), per stick profile, and with
//! `--cases` every case.
//! docs/OPERATOR.md, "Closed loop in manual mode", has its output.

mod study;

use study::{all_cases, case_lines, table_by_plant, table_by_profile, table_by_rope, ROPES};

fn main() -> Result<(), String> {
    let mut threads = 1;
    let mut ropes = ROPES.to_vec();
    let mut cases = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--threads" => {
                threads = args
                    .next()
                    .and_then(|n| n.parse().ok())
                    .ok_or("--threads N")?;
            }
            "--ropes" => {
                ropes = args
                    .next()
                    .ok_or("--ropes L,L,…")?
                    .split(',')
                    .map(|l| l.parse::<f64>().map_err(|e| format!("--ropes: {e}")))
                    .collect::<Result<_, _>>()?;
            }
            "--cases" => cases = true,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    let outcomes = all_cases(&ropes, threads);
    println!("## Per rope length (every plant and profile, the hoist still and lowering)\n");
    println!("{}", table_by_rope(&outcomes, &ropes));
    println!("## Per plant (every profile and rope length, the hoist still and lowering)\n");
    println!("{}", table_by_plant(&outcomes));
    println!("## Per profile (every plant and rope length, the hoist still and lowering)\n");
    println!("{}", table_by_profile(&outcomes));
    if cases {
        println!("## Every case\n");
        println!("{}", case_lines(&outcomes));
    }
    Ok(())
}
