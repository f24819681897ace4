//! Republishing a session over DDS with its recorded timing, as `ros2 bag play` does.

use crate::msgs::{
    Clock, DiagnosticArray, JointState, LegForce, ModelParams, RosMessage, Time, WrenchStamped,
};
use crate::node::dds::{publisher, tool_node};
use crate::record::read::{read_session, same_type};
use crate::session::files::read_file;
use anyhow::{Context as _, Result};
use ros2_client::Publisher;
use std::future::Future;
use std::path::Path;
use std::time::{Duration, Instant};

/// How to replay.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayOptions {
    /// Speed against the recorded timing (2 plays twice as fast).
    pub rate: f64,
    /// Publish without waiting.
    pub as_fast_as_possible: bool,
    /// Only these topics (all when empty).
    pub topics: Vec<String>,
    /// Start again at the end, until stopped.
    pub repeat: bool,
    /// Publish `/clock` (`rosgraph_msgs/Clock`) at this rate (Hz) with the recording's time, as
    /// `ros2 bag play --clock` does, for nodes that run with `use_sim_time`.
    pub clock_hz: Option<f64>,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            rate: 1.0,
            as_fast_as_possible: false,
            topics: Vec::new(),
            repeat: false,
            clock_hz: None,
        }
    }
}

/// What a replay published.
#[derive(Debug, Clone, Default)]
pub struct Replayed {
    /// Messages published.
    pub sent: u64,
    /// Messages that did not decode (counted, not published).
    pub undecodable: u64,
    /// Topics of the file not replayed (unknown type or encoding), with their type.
    pub skipped: Vec<String>,
}

enum AnyPub {
    Joints(Publisher<JointState>),
    Wrench(Publisher<WrenchStamped>),
    Force(Publisher<LegForce>),
    Params(Publisher<ModelParams>),
    Diag(Publisher<DiagnosticArray>),
}

/// Publishes the messages of `file` in log-time order with their recorded timing until the end
/// (or, with `repeat`, until `stop` resolves). `progress` gets the messages sent so far and in
/// all. Runs on the calling thread's tokio runtime.
pub async fn replay(
    file: &Path,
    opts: &ReplayOptions,
    stop: impl Future<Output = ()>,
    mut progress: impl FnMut(u64, u64),
) -> Result<Replayed> {
    if !(opts.rate.is_finite() && opts.rate > 0.0) {
        anyhow::bail!("replay rate {}: must be a positive number", opts.rate);
    }
    if let Some(hz) = opts.clock_hz
        && !(hz.is_finite() && hz > 0.0 && hz <= 10_000.0)
    {
        anyhow::bail!("clock rate {hz} Hz: must be a number in (0, 10000]");
    }
    let bytes = read_file(file)?;
    let mut session = read_session(&bytes).with_context(|| file.display().to_string())?;
    // Played in log-time order: chunks may overlap in time (the node's outputs are in chunks of
    // their own, and other tools interleave too). Stable, so ties keep the file's order.
    session.messages.sort_by_key(|m| m.log_time_ns);
    let wanted = |t: &str| opts.topics.is_empty() || opts.topics.iter().any(|w| w == t);
    let mut node = tool_node(&format!("terzaghi_replay_{}", std::process::id())).context(
        crate::session::Failure("cannot create the replay node".into()),
    )?;
    let mut pubs: Vec<Option<AnyPub>> = Vec::new();
    let mut out = Replayed::default();
    for t in &session.topics {
        let p = if !wanted(&t.topic) || t.encoding != "cdr" {
            None
        } else if same_type(&t.type_name, &JointState::type_name()) {
            Some(AnyPub::Joints(publisher(&mut node, &t.topic)?))
        } else if same_type(&t.type_name, &WrenchStamped::type_name()) {
            Some(AnyPub::Wrench(publisher(&mut node, &t.topic)?))
        } else if same_type(&t.type_name, &LegForce::type_name()) {
            Some(AnyPub::Force(publisher(&mut node, &t.topic)?))
        } else if same_type(&t.type_name, &ModelParams::type_name()) {
            Some(AnyPub::Params(publisher(&mut node, &t.topic)?))
        } else if same_type(&t.type_name, &DiagnosticArray::type_name()) {
            Some(AnyPub::Diag(publisher(&mut node, &t.topic)?))
        } else {
            None
        };
        if p.is_none() && wanted(&t.topic) {
            out.skipped.push(format!("{} ({})", t.topic, t.type_name));
        }
        pubs.push(p);
    }
    // `/clock` and its period.
    let clock = match opts.clock_hz {
        Some(hz) => Some((
            publisher::<Clock>(&mut node, "/clock")?,
            Duration::from_secs_f64(1.0 / hz),
        )),
        None => None,
    };
    let spin = tokio::spawn(node.spinner()?.spin());
    // Let subscribers discover the publishers before the first message.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let total = session.messages.len() as u64;
    tokio::pin!(stop);
    'outer: loop {
        let t0 = session.messages.first().map(|m| m.log_time_ns).unwrap_or(0);
        let start = Instant::now();
        let mut next_clock = start;
        for (i, m) in session.messages.iter().enumerate() {
            let Some(p) = &pubs[m.topic] else { continue };
            if !opts.as_fast_as_possible {
                let due = start
                    + Duration::from_secs_f64(
                        m.log_time_ns.saturating_sub(t0) as f64 * 1e-9 / opts.rate,
                    );
                // /clock ticks while waiting for the message, with the recording's time running
                // on with the wall clock (scaled by the rate) between messages.
                while let Some((c, period)) = &clock {
                    if next_clock > due {
                        break;
                    }
                    tokio::select! {
                        _ = tokio::time::sleep_until(next_clock.into()) => {}
                        _ = &mut stop => break 'outer,
                    }
                    publish_clock(
                        c,
                        t0 + (start.elapsed().as_secs_f64() * opts.rate * 1e9) as u64,
                    );
                    next_clock += *period;
                }
                tokio::select! {
                    _ = tokio::time::sleep_until(due.into()) => {}
                    _ = &mut stop => break 'outer,
                }
            } else if let Some((c, period)) = &clock
                && Instant::now() >= next_clock
            {
                // As fast as possible, the recording's time is the message's.
                publish_clock(c, m.log_time_ns);
                next_clock = Instant::now() + *period;
            }
            let ok = match p {
                AnyPub::Joints(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                AnyPub::Wrench(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                AnyPub::Force(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                AnyPub::Params(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
                AnyPub::Diag(p) => session.decode(m).map(|x| p.publish(x).is_ok()),
            };
            match ok {
                Ok(_) => out.sent += 1,
                Err(_) => out.undecodable += 1,
            }
            if i % 1000 == 0 {
                progress(i as u64, total);
            }
        }
        if !opts.repeat {
            break;
        }
    }
    node.stop_spinner();
    let _ = tokio::time::timeout(Duration::from_secs(1), spin).await;
    Ok(out)
}

fn publish_clock(p: &Publisher<Clock>, ns: u64) {
    let t = Time::from_nanos(ns.min(i64::MAX as u64) as i64).unwrap_or_default();
    let _ = p.publish(Clock { clock: t });
}
