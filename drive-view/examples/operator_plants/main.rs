//! The closed loop in manual mode on plants that are not the model, each error alone and
//! combined (issue 28): `cargo run -p drive-view --example operator_plants -- [--threads N]
//! [--ropes 3.5,8] [--plants NAME,…] [--robust] [--more] [--cases]`. Prints the table per
//! rope length and per plant
//! (median and worst of the load's error, the swing one swing period after rest and the
//! feedback's correction travel; `study.rs` says what each is), per stick profile and per
//! hoist lever, per plant the correction travel beside how far the drives themselves went
//! off a drive like the model's, and with `--cases` every case. Without `--more` the first study's cases
//! (`study::Study::First`), with it the cases it left out (`study::Study::More`: pulsing,
//! pendant levels, the hoist raising, a P-only hoist, the 3D crane's trolley).
//! `--plants` keeps the plants whose name starts with one of the names given (`rope`,
//! `all`, `view`); `--robust` runs the generator with its robust setting, where the
//! study's scenes run it plain.
//! docs/OPERATOR.md, "Closed loop in manual mode", has its output.

mod study;
mod tables;

use study::{all_cases, Generator, Study, ROPES};

fn main() -> Result<(), String> {
    let mut threads = 1;
    let mut ropes = ROPES.to_vec();
    let mut cases = false;
    let mut study = Study::First;
    let mut generator = Generator::Plain;
    let mut plants: Vec<String> = Vec::new();
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
            "--more" => study = Study::More,
            "--robust" => generator = Generator::Robust,
            "--plants" => {
                plants = args
                    .next()
                    .ok_or("--plants NAME,…")?
                    .split(',')
                    .map(str::to_owned)
                    .collect();
            }
            "--cases" => cases = true,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    let keep =
        |name: &str| plants.is_empty() || plants.iter().any(|p| name.starts_with(p.as_str()));
    let outcomes = all_cases(study, &ropes, &keep, generator, threads);
    if outcomes.is_empty() {
        return Err(format!("no plant's name starts with any of {plants:?}"));
    }
    println!("## Per rope length ({study:?}, generator {generator:?}: every plant, profile and hoist lever)\n");
    println!("{}", tables::by_rope(&outcomes));
    println!("## Per plant (every profile, rope length and hoist lever)\n");
    println!("{}", tables::by_plant(&outcomes));
    println!("## Per plant, where the drives went (every profile, rope length and hoist lever)\n");
    println!("{}", tables::drive_paths(&outcomes));
    println!("## Per profile (every plant, rope length and hoist lever)\n");
    println!("{}", tables::by_profile(&outcomes));
    println!("## Per hoist lever (every plant, profile and rope length)\n");
    println!("{}", tables::by_hoist(&outcomes));
    if cases {
        println!("## Every case\n");
        println!("{}", tables::case_lines(&outcomes));
    }
    Ok(())
}
