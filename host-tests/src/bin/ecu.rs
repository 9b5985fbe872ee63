//! `ecu`: the virtual ECU — the firmware's controller, built for a scene exactly as the
//! firmware builds it, run in real time (one tick per h by the wall clock) with its CAN
//! bus exposed as SLCAN (Lawicel ASCII) over TCP on 127.0.0.1, so that python-can
//! (`can.Bus(interface="slcan", channel="socket://127.0.0.1:PORT")`), python-canopen and,
//! through `slcand`, SocketCAN tools talk to it.
//!
//! ```text
//! ecu [--scene FILE] [--port N] [--role manager|slave] [--demo] [--seconds S] [--log FILE]
//! ecu [--scene FILE] --reference X,Z,DURATION
//! ecu [--scene FILE] --drives-at-rest [X,Z]
//! ```
//!
//! Every TCP client is a node on one CAN bus: a frame a client sends reaches the
//! controller (at its next tick, as the firmware takes the frames received since the
//! last cycle) and every other open client; the controller's frames reach every open
//! client. Nothing is echoed to its sender (as on a real adapter). The first line on
//! stdout is `listening on 127.0.0.1:PORT` (with `--port 0` the port the system chose).
//! The run ends by itself after `--seconds`; the log (`--log`) has one line per frame
//! in both directions in candump's `-l` layout, `(seconds) sender ID#DATA`, where the
//! sender is `ecu` for the controller and `tcpN` for the N-th client; it is flushed
//! every tick.
//!
//! SLCAN as python-can 4.6's `slcan` interface and Linux's `slcand` use it: `O` and `L`
//! open (`L` listen-only), `C` closes, `Sn`/`sxxyy` set the bit rate while closed, `V`,
//! `v`, `N` and `F` report version, serial number and status, `Z0`/`Z1` switch receive
//! timestamps, `M`/`m`/`X`/`W` are accepted: each answered with `\r` (the reply text
//! before it where there is one), anything else with `\a`. `tIIILDD…` and `TIIIIIIIILDD…`
//! (and `r`/`R`) transmit while open; nothing answers a transmitted frame (as on the
//! CANable's firmware), a frame while closed is answered with `\a`.

use std::io::{BufWriter, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use clap::{Parser, ValueEnum};
use controller::commands::Request;
use controller::correction::AxesCorrection;
use controller::crane::command_plan;
use controller::drive::Drive;
use controller::node::Role;
use controller::{CanFrame, Controller, Feedforward, Injectable, Mode, Replan};
use host_tests::firmware::{with_controller, WithController};
use scene::commissioning::CommissioningFile;
use scene::dispatch::{firmware, FirmwareCrane, FirmwareCraneVisitor};
use scene::firmware::FirmwareScene;
use scene::Scene;

#[derive(Parser, Debug)]
#[command(about = "The crane controller in real time, its CAN bus as SLCAN over TCP")]
struct Cli {
    /// The scene (the default scene, `host_tests::DEFAULT_SCENE`, unless given).
    #[arg(long, default_value = host_tests::DEFAULT_SCENE)]
    scene: PathBuf,
    /// TCP port on 127.0.0.1; 0 lets the system choose (printed on the first line).
    #[arg(long, default_value_t = 28_800)]
    port: u16,
    /// NMT role: manager (starts the drives) or slave (waits for a PLC's start).
    #[arg(long, value_enum, default_value_t = RoleArg::Manager)]
    role: RoleArg,
    /// Run the scene's own move as a demonstration (default: no motion without a command).
    #[arg(long)]
    demo: bool,
    /// Stop after this many seconds (the ECU always stops by itself).
    #[arg(long, default_value_t = 300.0)]
    seconds: f64,
    /// Write every frame, both directions, with timestamps, to this file.
    #[arg(long)]
    log: Option<PathBuf>,
    /// No bus: print the set points (µm/s in the model's input order, one cycle a line:
    /// `trolley winch`, the 3D crane's `bridge trolley winch`) the same controller sends
    /// for a move to X,Z (the 3D crane: X,Y,Z; m) in DURATION s (0: as fast as the limits
    /// allow), on the virtual bus's stock drives from the moment it is accepted — the
    /// host's computation that a run on the bus is compared with.
    #[arg(long, value_name = "X,Z,DURATION")]
    reference: Option<String>,
    /// No bus: print where the scene's crane's drives stand while the load rests at X,Z
    /// (the 3D crane: X,Y,Z; m), without a value where the scene's move starts: one
    /// line, each drive's position in m in the model's input order (`trolley winch`, the
    /// 3D crane's `bridge trolley winch`) — the crane's `drives_at_rest`, where the
    /// interop suite's drives power up (the hook-and-load crane's rope a sling shorter
    /// than the load is deep).
    #[arg(long, value_name = "X,Z", num_args = 0..=1, default_missing_value = "start")]
    drives_at_rest: Option<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum RoleArg {
    Manager,
    Slave,
}

/// The longest run allowed: a day.
const MAX_SECONDS: f64 = 86_400.0;

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("ecu: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: &Cli) -> Result<(), String> {
    if !(cli.seconds > 0.0 && cli.seconds <= MAX_SECONDS) {
        return Err(format!(
            "--seconds {}: must be in (0, {MAX_SECONDS}]",
            cli.seconds
        ));
    }
    let scene = Scene::load(&cli.scene).map_err(|e| format!("{}: {e}", cli.scene.display()))?;
    let commissioning = CommissioningFile::for_scene(&cli.scene).map_err(|e| e.to_string())?;
    // The scene's crane, as the firmware's build script makes it a type.
    firmware(&scene, &commissioning, Ecu { cli, scene: &scene })?
}

/// The ECU for a scene, whatever its crane.
struct Ecu<'a> {
    cli: &'a Cli,
    scene: &'a Scene,
}

impl FirmwareCraneVisitor for Ecu<'_> {
    type Output = Result<(), String>;

    fn visit<K: FirmwareCrane<A>, const A: usize>(self, f: FirmwareScene<K, A>) -> Self::Output {
        let (cli, scene) = (self.cli, self.scene);
        // No motion without a command: the scene's move only when asked (as the QEMU
        // main job asks for it); otherwise the crane rests where the scene's move starts.
        let plan = if cli.demo {
            f.plan
        } else {
            command_plan::<K, A>(f.start(), scene.trajectory.smoothness)
                .map_err(|e| e.to_string())?
        };
        if let Some(spec) = &cli.drives_at_rest {
            let load = if spec == "start" {
                f.start()
            } else {
                load_position::<A>(spec)?
            };
            let drives = f.planner.drives_at_rest(load);
            return host_tests::output::emit(&format!(
                "{}\n",
                drives.map(|p| p.to_string()).join(" ")
            ));
        }
        if let Some(spec) = &cli.reference {
            let request = reference_request(spec, A)?;
            return with_controller(scene, &f, plan, f.config, Reference { request })?;
        }
        let listener = TcpListener::bind(("127.0.0.1", cli.port))
            .map_err(|e| format!("cannot listen on 127.0.0.1:{}: {e}", cli.port))?;
        let port = listener.local_addr().map_err(|e| e.to_string())?.port();
        let log = match &cli.log {
            Some(path) => {
                if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
                }
                let file =
                    std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
                Some(BufWriter::new(file))
            }
            None => None,
        };
        println!("listening on 127.0.0.1:{port}");
        eprintln!(
            "ecu: scene {} ({}), role {:?}, drives {}, {}{}, {}, for {} s",
            scene.name,
            cli.scene.display(),
            cli.role,
            K::DRIVES
                .map(|d| format!("{} (node {})", d.name(), node_of(&f.config, d)))
                .join(", "),
            match f.config.inclinometer() {
                Some(i) if f.feedback.is_some() => {
                    format!("state feedback with the inclinometer at node {}", i.node)
                }
                _ => "feedforward only".into(),
            },
            if f.operator.is_some() {
                ", manual mode (the operator's frames on 0x410, 0x2010)"
            } else {
                ""
            },
            if cli.demo {
                "with the scene's move"
            } else {
                "at rest until a command"
            },
            cli.seconds
        );
        let _ = std::io::stdout().flush();
        let setup = Setup {
            duration: Duration::from_secs_f64(cli.seconds),
            listener,
            bus: Arc::new(Mutex::new(Bus::new(log))),
        };
        let config = controller::Config {
            role: match cli.role {
                RoleArg::Manager => Role::Manager,
                RoleArg::Slave => Role::Slave,
            },
            ..f.config
        };
        // The firmware's controller for the scene, built as the host's run of the
        // firmware builds it (one construction: crane, model, scheme, Newton strategy,
        // feedback).
        with_controller(scene, &f, plan, config, setup)?
    }
}

/// The move `--reference` asks of a crane with `axes` driven axes, id 1: `X,Z,DURATION`
/// (the 3D crane's `X,Y,Z,DURATION`). A duration of 0 asks, as on the frames, for the
/// move as fast as the limits allow (`None`): `Some(0.0)` would go over the wire as the
/// shortest duration the frame can carry (10 ms, 1 s for the 3D move) instead.
fn reference_request(spec: &str, axes: usize) -> Result<Request, String> {
    let numbers: Vec<f64> = spec
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("--reference {spec}: {e}"))?;
    let given = |d: f64| (d != 0.0).then_some(d);
    match numbers[..] {
        [x, z, duration] if axes == 2 => Ok(Request::Move {
            id: 1,
            target: [x, z],
            duration: given(duration),
        }),
        [x, y, z, duration] if axes == 3 => Ok(Request::Move3d {
            id: 1,
            target: [x, y, z],
            duration: given(duration),
        }),
        _ => Err(format!(
            "--reference {spec}: {} for this crane",
            if axes == 3 {
                "X,Y,Z,DURATION"
            } else {
                "X,Z,DURATION"
            }
        )),
    }
}

/// The load's position `--drives-at-rest` names for a crane with `A` driven axes:
/// `X,Z` (the 3D crane's `X,Y,Z`), m, each finite.
fn load_position<const A: usize>(spec: &str) -> Result<[f64; A], String> {
    let numbers: Vec<f64> = spec
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("--drives-at-rest {spec}: {e}"))?;
    match <[f64; A]>::try_from(numbers) {
        Ok(load) if load.iter().all(|v| v.is_finite()) => Ok(load),
        _ => Err(format!(
            "--drives-at-rest {spec}: {} finite numbers for this crane",
            if A == 3 { "X,Y,Z: three" } else { "X,Z: two" }
        )),
    }
}

/// The node id the commissioning file gives `drive` (0: none).
fn node_of(config: &controller::Config, drive: Drive) -> u8 {
    config.drive(drive).map_or(0, |d| d.node)
}

/// Print the set points of one move on the virtual bus.
struct Reference {
    /// The move, id 1.
    request: Request,
}

impl WithController for Reference {
    type Output = Result<(), String>;

    fn with<F, C, K, const A: usize>(
        self,
        controller: Controller<Injectable<F>, C, K, A>,
        f: &FirmwareScene<K, A>,
    ) -> Self::Output
    where
        F: Feedforward<A, Reference = K::Reference> + Replan<A>,
        C: AxesCorrection<A, K::Reference>,
        K: FirmwareCrane<A>,
    {
        reference(controller, f, self.request)
    }
}

impl WithController for Setup {
    type Output = Result<(), String>;

    fn with<F, C, K, const A: usize>(
        self,
        controller: Controller<Injectable<F>, C, K, A>,
        _: &FirmwareScene<K, A>,
    ) -> Self::Output
    where
        F: Feedforward<A, Reference = K::Reference> + Replan<A>,
        C: AxesCorrection<A, K::Reference>,
        K: FirmwareCrane<A>,
    {
        serve(controller, self)
    }
}

/// The set points of one move as the controller computes them on the virtual bus's
/// stock CiA 402 drives (no real time, no TCP): ready, the move asked, then every
/// cycle's set points (µm/s, in the model's input order) from the one that answers it
/// until the drives rest. A 3D move's duration goes over the wire in whole seconds.
fn reference<F, C, K, const A: usize>(
    mut controller: Controller<Injectable<F>, C, K, A>,
    f: &FirmwareScene<K, A>,
    request: Request,
) -> Result<(), String>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: FirmwareCrane<A>,
{
    use controller::commands::{request_frame, Answer};
    use sim::{run_cycle, HEALTHY};
    let duration = match request {
        Request::Move { duration, .. } | Request::Move3d { duration, .. } => duration,
        Request::Stop { .. } | Request::Reset { .. } => None,
    }
    .unwrap_or(0.0);
    let mut bus = host_tests::firmware::virtual_bus(f, HEALTHY)?;
    let period = controller.config().period_ms;
    let limit = 100 * 1000 / period + (duration * 1000.0) as u32 / period;
    let (mut asked, mut answered) = (false, false);
    let mut rest = 0;
    for cycle in 0..limit {
        let now = cycle * period;
        if !asked && controller.mode() == Mode::Ready {
            controller.on_frame(&request_frame(&request), u64::from(now));
            asked = true;
        }
        let out = run_cycle(&mut controller, &mut bus, now)
            .ok_or("the virtual bus hung the controller")?;
        match controller.last_answer() {
            (1, Answer::Accepted, None) => answered = true,
            (1, answer, reason) => return Err(format!("the move was {answer:?} {reason:?}")),
            _ => {}
        }
        if answered {
            let units = out.setpoints.map(|s| s.units());
            host_tests::output::emit(&format!("{}\n", units.map(|u| u.to_string()).join(" ")))?;
            let moving = controller
                .feedforward()
                .plan()
                .is_moving(f64::from(now) / 1e3);
            rest = if units.iter().all(|u| *u == 0) && !moving {
                rest + 1
            } else {
                0
            };
            if rest > 10 {
                return Ok(());
            }
        }
    }
    Err("the move did not end".into())
}

/// Everything a real-time run needs besides the controller.
struct Setup {
    duration: Duration,
    listener: TcpListener,
    bus: Arc<Mutex<Bus>>,
}

/// The real-time loop: tick k at k·h after the start by the wall clock, the frames
/// received since the last tick fed first (with the tick's time, as the firmware does);
/// a late tick runs at once, so the controller's time stays k·h.
///
/// A tick whose frames go out more than a period late (the host stalled this process: a
/// loaded machine, a write waiting on the disk) makes the ticks after it keep the period
/// from then: the schedule slips instead of running the missed ticks back to back. Run
/// back to back, they sent their SYNCs within a millisecond and advanced the
/// controller's clock by the stall while the drives had no time to answer one: a 60 ms
/// stall of the ECU alone ended in fault 10, its drives' TPDOs "50 ms late" (interop
/// README, "Keeping time"). The firmware on its own processor is not stalled by a host;
/// its supervision (50 ms without a TPDO is a fault) is unchanged — the controller's
/// clock only never runs ahead of the time its drives had.
fn serve<F, C, K, const A: usize>(
    mut controller: Controller<Injectable<F>, C, K, A>,
    setup: Setup,
) -> Result<(), String>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: FirmwareCrane<A>,
{
    let config = *controller.config();
    let period = Duration::from_millis(u64::from(config.period_ms));
    let stop = Arc::new(AtomicBool::new(false));
    let acceptor = {
        let (bus, stop) = (Arc::clone(&setup.bus), Arc::clone(&stop));
        let listener = setup.listener;
        std::thread::spawn(move || accept(&listener, &bus, &stop))
    };
    // Tick k is due `k - anchor_k` periods after `anchor`: the start, or the last tick
    // that ran more than a period late.
    let (mut anchor, mut anchor_k) = (lock(&setup.bus).start, 0u64);
    let cycles = (setup.duration.as_nanos() / period.as_nanos()).max(1) as u64;
    let mut late = 0u64;
    let mut worst = Duration::ZERO;
    for k in 0..cycles {
        let due = anchor + period * u32::try_from(k - anchor_k).unwrap_or(u32::MAX);
        let now = Instant::now();
        if now < due {
            std::thread::sleep(due - now);
        }
        let now_ms = k * u64::from(config.period_ms);
        let received = std::mem::take(&mut lock(&setup.bus).inbox);
        for frame in &received {
            controller.on_frame(frame, now_ms);
        }
        let began = Instant::now();
        let out = controller.tick(now_ms);
        worst = worst.max(began.elapsed());
        let mut bus = lock(&setup.bus);
        for frame in &out.frames {
            bus.deliver(None, &Frame::from(frame));
        }
        // Late, whether the sleep overran or the tick waited for the bus: the next one
        // a period after these frames went out.
        let sent = Instant::now();
        if sent.saturating_duration_since(due) > period {
            late += 1;
            (anchor, anchor_k) = (sent, k);
        }
        bus.flush_log();
    }
    stop.store(true, Ordering::SeqCst);
    lock(&setup.bus).close_all();
    let _ = acceptor.join();
    let bus = lock(&setup.bus);
    let c = controller.counters();
    eprintln!(
        "ecu: {cycles} cycles, mode {}, {} frames sent, {} received ({} ignored), \
         {} drives commissioned, {} warnings; {} clients, {} ticks more than a period late, \
         longest tick {:.2} ms",
        mode_name(controller.mode()),
        c.frames_sent,
        c.frames_received,
        c.frames_ignored,
        c.commissioned,
        c.drive_warnings,
        bus.next_client - 1,
        late,
        worst.as_secs_f64() * 1e3
    );
    Ok(())
}

fn mode_name(mode: Mode) -> String {
    match mode.fault() {
        Some(f) => format!("{mode:?} (fault {})", f.code()),
        None => format!("{mode:?}"),
    }
}

fn lock(bus: &Mutex<Bus>) -> MutexGuard<'_, Bus> {
    // A reader thread that panicked leaves the bus usable: it only holds plain data.
    bus.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Accepts clients until the run ends; each gets a reader thread.
fn accept(listener: &TcpListener, bus: &Arc<Mutex<Bus>>, stop: &Arc<AtomicBool>) {
    if listener.set_nonblocking(true).is_err() {
        return;
    }
    while !stop.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((stream, _)) => {
                let _ = stream.set_nonblocking(false);
                let _ = stream.set_nodelay(true);
                let _ = stream.set_write_timeout(Some(Duration::from_millis(200)));
                let Ok(writer) = stream.try_clone() else {
                    continue;
                };
                let id = lock(bus).join(writer);
                let (bus, stop) = (Arc::clone(bus), Arc::clone(stop));
                std::thread::spawn(move || read_client(stream, id, &bus, &stop));
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(_) => std::thread::sleep(Duration::from_millis(5)),
        }
    }
}

/// One client's SLCAN commands, line by line, until it disconnects or the run ends.
fn read_client(mut stream: TcpStream, id: usize, bus: &Mutex<Bus>, stop: &AtomicBool) {
    let _ = stream.set_read_timeout(Some(Duration::from_millis(100)));
    let mut line = Vec::with_capacity(64);
    let mut buf = [0u8; 512];
    while !stop.load(Ordering::SeqCst) {
        let n = match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                continue
            }
            Err(_) => break,
        };
        for &b in buf.iter().take(n) {
            if b == b'\r' || b == b'\n' {
                if !line.is_empty() {
                    lock(bus).command(id, &line);
                    line.clear();
                }
            } else if line.len() < 64 {
                line.push(b);
            }
        }
    }
    lock(bus).leave(id);
}

/// A frame on the bus: 11- or 29-bit identifier, remote or data.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Frame {
    id: u32,
    extended: bool,
    remote: bool,
    dlc: u8,
    data: Vec<u8>,
}

impl From<&CanFrame> for Frame {
    fn from(f: &CanFrame) -> Self {
        Self {
            id: u32::from(f.id()),
            extended: false,
            remote: false,
            dlc: f.data().len() as u8,
            data: f.data().to_vec(),
        }
    }
}

impl Frame {
    /// The SLCAN text (without `\r`), with a receive timestamp in ms if given.
    fn slcan(&self, timestamp_ms: Option<u16>) -> String {
        let kind = match (self.extended, self.remote) {
            (false, false) => 't',
            (true, false) => 'T',
            (false, true) => 'r',
            (true, true) => 'R',
        };
        let mut s = if self.extended {
            format!("{kind}{:08X}{}", self.id, self.dlc)
        } else {
            format!("{kind}{:03X}{}", self.id, self.dlc)
        };
        for b in &self.data {
            s.push_str(&format!("{b:02X}"));
        }
        if let Some(t) = timestamp_ms {
            s.push_str(&format!("{t:04X}"));
        }
        s
    }

    /// candump's `ID#DATA` (`ID#R` for a remote frame).
    fn candump(&self) -> String {
        let mut s = if self.extended {
            format!("{:08X}#", self.id)
        } else {
            format!("{:03X}#", self.id)
        };
        if self.remote {
            s.push('R');
        }
        for b in &self.data {
            s.push_str(&format!("{b:02X}"));
        }
        s
    }

    /// The frame of an SLCAN transmit command (`t`, `T`, `r`, `R`), if well formed.
    fn parse(line: &[u8]) -> Option<Self> {
        let (&kind, rest) = line.split_first()?;
        let (extended, remote) = match kind {
            b't' => (false, false),
            b'T' => (true, false),
            b'r' => (false, true),
            b'R' => (true, true),
            _ => return None,
        };
        let id_len = if extended { 8 } else { 3 };
        let text = std::str::from_utf8(rest).ok()?;
        let id = u32::from_str_radix(text.get(..id_len)?, 16).ok()?;
        if id > if extended { 0x1FFF_FFFF } else { 0x7FF } {
            return None;
        }
        let dlc = text.get(id_len..=id_len)?.parse::<u8>().ok()?;
        if dlc > 8 {
            return None;
        }
        let hex = text.get(id_len + 1..)?;
        let data = if remote {
            if !hex.is_empty() {
                return None;
            }
            Vec::new()
        } else {
            if hex.len() != 2 * usize::from(dlc) {
                return None;
            }
            (0..usize::from(dlc))
                .map(|i| u8::from_str_radix(hex.get(2 * i..2 * i + 2)?, 16).ok())
                .collect::<Option<Vec<u8>>>()?
        };
        Some(Self {
            id,
            extended,
            remote,
            dlc,
            data,
        })
    }

    /// The controller's kind of frame: 11-bit data frames.
    fn classic(&self) -> Option<CanFrame> {
        if self.extended || self.remote {
            return None;
        }
        CanFrame::new(u16::try_from(self.id).ok()?, &self.data).ok()
    }
}

struct Client {
    id: usize,
    stream: TcpStream,
    open: bool,
    listen_only: bool,
    timestamps: bool,
}

/// The virtual bus: its clients, the frames waiting for the controller's next tick, and
/// the log.
struct Bus {
    start: Instant,
    clients: Vec<Client>,
    next_client: usize,
    inbox: Vec<CanFrame>,
    log: Option<BufWriter<std::fs::File>>,
}

/// SLCAN version answered to `V` and `v`.
const VERSION: &str = "1013";
/// Serial number answered to `N`.
const SERIAL: &str = "ECU1";

impl Bus {
    fn new(log: Option<BufWriter<std::fs::File>>) -> Self {
        Self {
            start: Instant::now(),
            clients: Vec::new(),
            next_client: 1,
            inbox: Vec::new(),
            log,
        }
    }

    fn join(&mut self, stream: TcpStream) -> usize {
        let id = self.next_client;
        self.next_client += 1;
        self.clients.push(Client {
            id,
            stream,
            open: false,
            listen_only: false,
            timestamps: false,
        });
        eprintln!(
            "ecu: client tcp{id} connected at {:.3} s",
            self.start.elapsed().as_secs_f64()
        );
        id
    }

    fn leave(&mut self, id: usize) {
        if let Some(i) = self.clients.iter().position(|c| c.id == id) {
            let c = self.clients.remove(i);
            let _ = c.stream.shutdown(Shutdown::Both);
            eprintln!(
                "ecu: client tcp{id} left at {:.3} s",
                self.start.elapsed().as_secs_f64()
            );
        }
    }

    fn close_all(&mut self) {
        for c in self.clients.drain(..) {
            let _ = c.stream.shutdown(Shutdown::Both);
        }
        self.flush_log();
    }

    fn flush_log(&mut self) {
        if let Some(log) = &mut self.log {
            let _ = log.flush();
        }
    }

    /// Puts `frame` on the bus from client `from` (`None`: the controller): logged, sent
    /// to every other open client, and to the controller if it came from a client.
    fn deliver(&mut self, from: Option<usize>, frame: &Frame) {
        let t = self.start.elapsed();
        if let Some(log) = &mut self.log {
            let sender = from.map_or_else(|| "ecu".to_string(), |id| format!("tcp{id}"));
            let _ = writeln!(log, "({:.6}) {sender} {}", t.as_secs_f64(), frame.candump());
        }
        let stamp = (t.as_millis() % 60_000) as u16;
        let mut gone = Vec::new();
        for c in self.clients.iter_mut() {
            if !c.open || Some(c.id) == from {
                continue;
            }
            let mut text = frame.slcan(c.timestamps.then_some(stamp));
            text.push('\r');
            if c.stream.write_all(text.as_bytes()).is_err() {
                gone.push(c.id);
            }
        }
        for id in gone {
            self.leave(id);
        }
        if from.is_some() {
            if let Some(f) = frame.classic() {
                self.inbox.push(f);
            }
        }
    }

    /// One SLCAN command of client `id`, answered.
    fn command(&mut self, id: usize, line: &[u8]) {
        let first = line.first().copied().unwrap_or(0);
        if matches!(first, b't' | b'T' | b'r' | b'R') {
            let may_send = self
                .clients
                .iter()
                .any(|c| c.id == id && c.open && !c.listen_only);
            if let (true, Some(frame)) = (may_send, Frame::parse(line)) {
                self.deliver(Some(id), &frame);
                return;
            }
        }
        let Some(client) = self.clients.iter_mut().find(|c| c.id == id) else {
            return;
        };
        let arg = line.get(1..).unwrap_or_default();
        let closed = !client.open;
        let reply: Option<String> = match first {
            b'O' if arg.is_empty() && closed => {
                client.open = true;
                client.listen_only = false;
                Some(String::new())
            }
            b'L' if arg.is_empty() && closed => {
                client.open = true;
                client.listen_only = true;
                Some(String::new())
            }
            b'C' if arg.is_empty() => {
                client.open = false;
                Some(String::new())
            }
            b'S' if closed && matches!(arg, [b'0'..=b'8']) => Some(String::new()),
            b's' if closed && arg.len() == 4 => Some(String::new()),
            b'V' if arg.is_empty() => Some(format!("V{VERSION}")),
            b'v' if arg.is_empty() => Some(format!("v{VERSION}")),
            b'N' if arg.is_empty() => Some(format!("N{SERIAL}")),
            b'F' if arg.is_empty() => Some("F00".into()),
            b'Z' if matches!(arg, [b'0' | b'1']) => {
                client.timestamps = arg == b"1";
                Some(String::new())
            }
            b'M' | b'm' if arg.len() == 8 => Some(String::new()),
            b'X' | b'W' if arg.len() == 1 => Some(String::new()),
            _ => None,
        };
        let answer = match reply {
            Some(mut text) => {
                text.push('\r');
                text
            }
            None => "\x07".to_string(),
        };
        if client.stream.write_all(answer.as_bytes()).is_err() {
            self.leave(id);
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn slcan_frames_round_trip() {
        let f = Frame::parse(b"t2106010203040506").unwrap();
        assert_eq!(f.id, 0x210);
        assert_eq!(f.data, [1, 2, 3, 4, 5, 6]);
        assert_eq!(f.slcan(None), "t2106010203040506");
        assert_eq!(f.candump(), "210#010203040506");
        assert_eq!(f.slcan(Some(0x1234)), "t21060102030405061234");
        let sync = Frame::parse(b"t0800").unwrap();
        assert_eq!(sync.classic(), Some(CanFrame::new(0x80, &[]).unwrap()));
        let ext = Frame::parse(b"T1234567820102").unwrap();
        assert!(ext.extended && ext.classic().is_none());
        assert_eq!(ext.candump(), "12345678#0102");
        let rtr = Frame::parse(b"r7011").unwrap();
        assert!(rtr.remote && rtr.candump() == "701#R");
        for bad in [
            &b"t80"[..],
            b"t8001",
            b"t0809000000000000000000",
            b"t0801XYZ",
            b"tFFF0",
            b"x0800",
        ] {
            assert_eq!(
                Frame::parse(bad),
                None,
                "{:?}",
                String::from_utf8_lossy(bad)
            );
        }
        assert!(Frame::parse(b"t7FF0").is_some());
    }

    #[test]
    fn a_reference_of_duration_0_is_the_move_as_fast_as_the_limits_allow() {
        use controller::commands::request_frame;
        // Duration 0 is `None`, which the frames carry as 0 (as fast as the limits
        // allow); a `Some(0.0)` went out as 10 ms (planar: refused, invalid) and as 1 s
        // (3D: refused, the bridge would leave its runway).
        let planar = reference_request("13,7.5,0", 2).unwrap();
        assert_eq!(
            planar,
            Request::Move {
                id: 1,
                target: [13.0, 7.5],
                duration: None
            }
        );
        assert_eq!(request_frame(&planar).data()[6..], [0, 0]);
        let spatial = reference_request("13,3.5,7,0", 3).unwrap();
        assert_eq!(request_frame(&spatial).data()[7], 0);
        // A given duration stays given.
        let timed = reference_request("13,3.5,7,4", 3).unwrap();
        assert_eq!(request_frame(&timed).data()[7], 4);
        assert!(reference_request("13,7.5,4", 3).is_err());
        assert!(reference_request("13,3.5,7,4", 2).is_err());
    }

    #[test]
    fn the_controllers_frames_become_slcan_text() {
        let f = controller::canopen::heartbeat(0x10, controller::canopen::NmtState::Operational);
        assert_eq!(Frame::from(&f).slcan(None), "t710105");
    }
}
