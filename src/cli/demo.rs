//! `terzaghi demo`: the whole job in one command. A simulated six-legged robot walks on poppy
//! seeds; its joint states and F/T go through the node (in memory, or over DDS with `--dds`),
//! which predicts every leg's forces, learns the medium online and records the session; then the
//! recording is diagnosed, and the summary compares what the diagnosis found with what the
//! simulation hid.

use super::print_out;
use crate::demo::{Demo, Legs, Watch};
use anyhow::{Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::cell::RefCell;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use terzaghi::config::NodeConfig;
use terzaghi::msgs::{DiagnosticArray, LegForce, ModelParams, WrenchStamped};
use terzaghi::node::handle::Publish;
use terzaghi::sim::robot::DEMO_RATE_HZ;
use terzaghi::sim::robot::{Session, Truth};

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Simulated seconds of walking.
    #[arg(long, default_value_t = 60.0)]
    pub seconds: f64,
    /// Directory for the session (session.mcap), the diagnosis and the summary.
    #[arg(long, value_name = "DIR", default_value = "terzaghi-demo")]
    pub out: PathBuf,
    /// Run over real DDS on the ROS 2 network of this machine (ROS_DOMAIN_ID, and
    /// ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST to stay on loopback) instead of in memory.
    #[arg(long)]
    pub dds: bool,
    /// Speed against the robot's clock: 5 plays 60 s in 12 s. At most 20.
    #[arg(long, default_value_t = 5.0)]
    pub speed: f64,
    /// Seed of the walk and of the sensors.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The robot's legs: `plate` (flat, the improved Terzaghi model; the walk is diagnosed) or
    /// `c` (RHex's C-legs, RFT with its scale learnt online; the walk is re-evaluated with
    /// nothing fitted and as it ran).
    #[arg(long, value_enum, default_value = "plate")]
    pub legs: LegsArg,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LegsArg {
    Plate,
    C,
}

pub fn run(a: DemoArgs) -> Result<()> {
    if !(a.seconds.is_finite() && (10.0..=3600.0).contains(&a.seconds)) {
        bail!("--seconds must be in [10, 3600], got {}", a.seconds);
    }
    if !(a.speed.is_finite() && a.speed > 0.0 && a.speed <= 20.0) {
        bail!("--speed must be in (0, 20], got {}", a.speed);
    }
    let legs = match a.legs {
        LegsArg::Plate => Legs::Plate,
        LegsArg::C => Legs::C,
    };
    let demo = Demo::new(a.seconds, a.seed, &a.out, legs)?;
    eprintln!(
        "a six-legged robot walks {:.0} s on {} ({} Hz joint states and F/T, {} playback); the node {}:",
        a.seconds,
        demo.cfg.legs[0].preset.map_or("its medium", |p| p.name),
        DEMO_RATE_HZ,
        format_args!("{}x", a.speed),
        if a.dds {
            "runs over DDS"
        } else {
            "runs in memory"
        }
    );
    let view = LiveView::new(&demo.cfg, &demo.session, &demo.truth, legs);
    let walked = demo.walk(a.dds, a.speed, &view)?;
    view.finish();
    eprintln!(
        "{}",
        match legs {
            Legs::Plate => "diagnosing the recording...",
            Legs::C => "re-evaluating the recording...",
        }
    );
    let summary = demo.diagnose(&walked)?;
    print_out(&summary.text)
}

/// The latest prediction and estimate of every leg, for the live view.
struct LiveView {
    bar: ProgressBar,
    truth: Truth,
    names: Vec<String>,
    /// Per leg: latest predicted (drag, lift), running squared error and count over the last
    /// second of the robot's clock, and the latest estimate.
    state: RefCell<Vec<LegView>>,
    last_draw: RefCell<Instant>,
    session: Session,
    legs: Legs,
}

#[derive(Clone, Default)]
struct LegView {
    predicted: Option<(f64, f64)>,
    sq_err: f64,
    n: f64,
    rms_first: Option<f64>,
    rms: f64,
    estimate: Option<(f64, f64, bool)>,
}

impl LiveView {
    fn new(cfg: &NodeConfig, session: &Session, truth: &Truth, legs: Legs) -> LiveView {
        let bar = if std::io::stderr().is_terminal() {
            ProgressBar::new(session.t_s.len() as u64)
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {percent:>3}% of the walk, {elapsed}\n{msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        LiveView {
            bar,
            truth: truth.clone(),
            names: cfg.legs.iter().map(|l| l.name.clone()).collect(),
            state: RefCell::new(vec![LegView::default(); cfg.legs.len()]),
            last_draw: RefCell::new(Instant::now()),
            session: session.clone(),
            legs,
        }
    }

    /// After the node handled JointState `k`: compare each leg's prediction with what its
    /// sensor measured at that instant.
    fn after_joints_impl(&self, k: usize) {
        let mut st = self.state.borrow_mut();
        for (leg, v) in st.iter_mut().enumerate() {
            if let (Some((d, l)), Some(m)) = (v.predicted, self.session.legs[leg].get(k)) {
                v.sq_err += (d - m.drag_n).powi(2) + (l - m.lift_n).powi(2);
                v.n += 2.0;
            }
            // A window of two seconds of the walk (more than a stroke).
            if v.n >= 4.0 * DEMO_RATE_HZ {
                v.rms = (v.sq_err / v.n).sqrt();
                v.rms_first.get_or_insert(v.rms);
                v.sq_err = 0.0;
                v.n = 0.0;
            }
        }
        drop(st);
        if self.last_draw.borrow().elapsed() > Duration::from_millis(200) {
            *self.last_draw.borrow_mut() = Instant::now();
            self.bar.set_position(k as u64 + 1);
            self.bar.set_message(self.table());
        }
    }

    fn table(&self) -> String {
        let curved = self.legs == Legs::C;
        let (first, second) = if curved {
            ("RFT scale", "")
        } else {
            ("b_k", "a")
        };
        let mut s = format!(
            "{:<13} {:>9} {:>7} {:>10}   prediction RMS error (last 2 s, first 2 s)\n",
            "leg", first, second, "converged"
        );
        for (name, v) in self.names.iter().zip(self.state.borrow().iter()) {
            let (b_k, a, conv) = v.estimate.unwrap_or((f64::NAN, f64::NAN, false));
            s += &format!(
                "{:<13} {:>9.3} {:>7} {:>10}   {:.2} N ({:.2} N)\n",
                name,
                b_k,
                if curved {
                    String::new()
                } else {
                    format!("{a:.3}")
                },
                if conv { "yes" } else { "no" },
                v.rms,
                v.rms_first.unwrap_or(f64::NAN)
            );
        }
        s += &if curved {
            format!(
                "(the medium as simulated: {:.2} times RFT's forces from poppy_lp's coefficients)",
                self.truth.rft_scale
            )
        } else {
            format!(
                "(the medium as simulated: b_k {:.2}, a {:.3}, plus effects the model leaves out)",
                self.truth.b_k, self.truth.a
            )
        };
        s
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
        eprintln!("{}", self.table());
    }
}

impl Publish for LiveView {
    fn wrench(&self, _leg: usize, _msg: WrenchStamped) {}
    fn force(&self, leg: usize, msg: LegForce) {
        if let Some(v) = self.state.borrow_mut().get_mut(leg) {
            v.predicted = Some((msg.drag_n, msg.lift_n));
        }
    }
    fn params(&self, leg: usize, msg: ModelParams) {
        if let Some(v) = self.state.borrow_mut().get_mut(leg) {
            // A C-leg's estimate is RFT's scale.
            let first = if self.legs == Legs::C {
                msg.rft_scale
            } else {
                msg.b_k
            };
            v.estimate = Some((first, msg.a, msg.converged));
        }
    }
    fn diagnostics(&self, _msg: DiagnosticArray) {}
    fn gap(&self, _leg: usize, _msg: terzaghi::msgs::Gap) {}
}

impl Watch for LiveView {
    fn after_joints(&self, k: usize) {
        self.after_joints_impl(k);
    }
}
