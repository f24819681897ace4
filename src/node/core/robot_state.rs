//! The robot's state from `/tf` and `/tf_static`: where each leg's hip is at a JointState's
//! stamp. A transform tree as tf2 keeps it (each frame's parent and its recent poses in it),
//! looked up from the hip's frame up to the world frame and interpolated in time; without I/O
//! or a clock.

use crate::config::{NodeConfig, RobotStateConfig};
use crate::model::HipMotion;
use crate::msgs::{
    Header, PoseStamped, TfMessage, Time, Transform, TransformStamped, Vector3 as MsgVector3,
};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use std::cell::{Cell, RefCell};
use std::collections::{HashMap, VecDeque};

/// Poses kept per frame: the newest within this span of the newest (and at most
/// [`MAX_POSES_PER_FRAME`]).
const HISTORY_NS: i64 = 2_000_000_000;
const MAX_POSES_PER_FRAME: usize = 4096;
/// Frames the tree numbers from transforms, at most (a large robot has a few hundred): a
/// publisher naming ever new frames costs a counted skip each beyond it, not memory without
/// bound.
const MAX_FRAMES: usize = 1024;
/// Frames followed from a hip up to the world, at most (a longer chain is a loop).
const MAX_DEPTH: usize = 64;
/// The hip's velocity: from its poses this long before the sample and at it.
const VELOCITY_SPAN_NS: i64 = 20_000_000;

/// Why the robot's state gave no hip at a stamp (the leg then uses its configured height).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoState {
    /// No transform links the hip's frame to the world frame (yet).
    Unknown,
    /// The transforms that link them are older (or newer) than `max_age_s` at the stamp.
    Stale,
    /// A transform was not a valid pose (non-finite, a zero quaternion).
    Invalid,
}

/// A frame's pose in its parent: fixed (`/tf_static`) or its recent stamped poses.
struct Link {
    parent: FrameId,
    fixed: Option<Isometry3<f64>>,
    poses: VecDeque<(i64, Isometry3<f64>)>,
}

/// A frame known to a [`TfTree`], by its name's number: lookups through the tree compare
/// numbers, not names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameId(usize);

/// The transform tree, fed by [`TfTree::insert`].
#[derive(Default)]
pub struct TfTree {
    /// Every frame named so far (by a transform or by [`TfTree::frame`]), to its number.
    ids: HashMap<String, FrameId>,
    /// By frame number: the frame's link to its parent, once a transform gave one.
    links: Vec<Option<Link>>,
    /// Transforms refused: non-finite values, a zero rotation, an invalid stamp, a frame that is
    /// its own parent, or a new frame beyond the most the tree numbers (1024).
    pub invalid: u64,
    /// The newest JointState stamp seen ([`TfTree::saw_joint_state`]).
    newest_joint_ns: Option<i64>,
    /// Frames' poses in the world found by recent lookups: the hips of one JointState share
    /// the body's chain, which is then walked once per stamp. Emptied by every insert.
    memo: RefCell<Vec<MemoEntry>>,
    /// The memo's oldest entry, once it is full.
    memo_next: Cell<usize>,
}

/// A frame's pose in `world` at `stamp` (looked up with `max_age_ns`).
struct MemoEntry {
    world: FrameId,
    frame: FrameId,
    stamp: i64,
    max_age_ns: i64,
    pose: Isometry3<f64>,
}

/// A hip a robot can have: every value finite, its height within a kilometre of the surface,
/// its speeds under 1 km/s, its pitch within a thousand radians and its place within a million
/// kilometres. A pose or transform far outside (a hip 1e304 m below the surface) would give
/// forces that are no number; it is invalid input instead, counted and skipped.
pub fn plausible_hip(h: &HipMotion) -> bool {
    let within = |v: f64, limit: f64| v.is_finite() && v.abs() <= limit;
    within(h.height_m, 1e3)
        && within(h.pitch_rad, 1e3)
        && within(h.forward_m_s, 1e3)
        && within(h.up_m_s, 1e3)
        && within(h.lateral_m_s, 1e3)
        && within(h.forward_position_m, 1e9)
}

/// Frames remembered: two stamps (the sample's and the one the hip's velocity is taken from)
/// of a few bodies.
const MEMO_ENTRIES: usize = 8;

fn isometry(t: &TransformStamped) -> Option<Isometry3<f64>> {
    let (v, q) = (t.transform.translation, t.transform.rotation);
    let values = [v.x, v.y, v.z, q.x, q.y, q.z, q.w];
    if values.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let q = Quaternion::new(q.w, q.x, q.y, q.z);
    if q.norm() < 1e-9 {
        return None;
    }
    Some(Isometry3::from_parts(
        Translation3::new(v.x, v.y, v.z),
        UnitQuaternion::from_quaternion(q),
    ))
}

/// The pose a fraction `t` of the way from `p0` to `p1`: the translation linear, the rotation
/// spherical (as tf2 interpolates). Between poses less than a degree apart (a robot's state at
/// hundreds of hertz) the normalised linear blend of the quaternions is used: it differs from the
/// spherical one by less than 1e-7 rad there and takes no `acos` and `sin`.
fn interpolate(p0: &Isometry3<f64>, p1: &Isometry3<f64>, t: f64) -> Isometry3<f64> {
    let translation = p0.translation.vector.lerp(&p1.translation.vector, t);
    let (q0, q1) = (p0.rotation, p1.rotation);
    let cos_half = q0.coords.dot(&q1.coords);
    let rotation = if cos_half.abs() >= NLERP_COS_HALF_ANGLE {
        // The shorter way round: q and -q are the same rotation.
        let q1 = if cos_half < 0.0 {
            -q1.into_inner()
        } else {
            q1.into_inner()
        };
        UnitQuaternion::new_normalize(q0.into_inner().lerp(&q1, t))
    } else {
        q0.slerp(&q1, t)
    };
    Isometry3::from_parts(Translation3::from(translation), rotation)
}

/// The cosine of half of one degree: rotations closer than that are blended linearly.
const NLERP_COS_HALF_ANGLE: f64 = 0.999_961_923_064_171_3;

/// How many of `poses` (in stamp order) are stamped at or before `stamp`, as `partition_point`
/// counts them, searched from the newest: the stamps a node asks for are among the last few
/// of a history of thousands, so the search reads a few neighbouring entries instead of a
/// binary search's scattered ones.
fn at_or_before(poses: &VecDeque<(i64, Isometry3<f64>)>, stamp: i64) -> usize {
    // Galloping back from the newest: every pose from `hi` on is after `stamp`.
    let (mut lo, mut hi) = (0, poses.len());
    let mut step = 1;
    while hi > 0 {
        let probe = hi.saturating_sub(step);
        if poses[probe].0 <= stamp {
            lo = probe + 1;
            break;
        }
        hi = probe;
        step *= 2;
    }
    // Then a binary search between: every pose before `lo` is at or before `stamp`.
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if poses[mid].0 <= stamp {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Frame names as tf2 compares them: without a leading `/`.
fn frame_name(name: &str) -> &str {
    name.strip_prefix('/').unwrap_or(name)
}

impl TfTree {
    /// The number of frame `name` (without a leading `/`), given one if it had none: a name
    /// the node looks up often (its world and hip frames) is numbered once, at start-up.
    pub fn frame(&mut self, name: &str) -> FrameId {
        let name = frame_name(name);
        if let Some(&id) = self.ids.get(name) {
            return id;
        }
        let id = FrameId(self.links.len());
        self.links.push(None);
        self.ids.insert(name.to_string(), id);
        id
    }

    /// The number of frame `name`, if it has one.
    fn known(&self, name: &str) -> Option<FrameId> {
        self.ids.get(frame_name(name)).copied()
    }

    /// Places the hips of `cfg`'s legs that give `<leg>.hip_offset_m` in
    /// `robot_state.body_frame`, as fixed transforms (a robot without TF gives its body's pose
    /// alone, [`TfTree::insert_pose`]).
    pub fn place_hips(&mut self, cfg: &NodeConfig) {
        let transforms = cfg
            .legs
            .iter()
            .filter_map(|l| {
                let ([x, y, z], frame) = (l.hip_offset_m?, l.hip_frame.clone()?);
                Some(TransformStamped {
                    header: Header {
                        stamp: Time::default(),
                        frame_id: cfg.robot_state.body_frame.clone(),
                    },
                    child_frame_id: frame,
                    transform: Transform {
                        translation: MsgVector3 { x, y, z },
                        ..Default::default()
                    },
                })
            })
            .collect();
        self.insert(&TfMessage { transforms }, true);
    }

    /// Takes the body's pose (`rs.pose_topic`): the pose of `rs.body_frame` in the message's
    /// frame (the world frame if it names none).
    pub fn insert_pose(&mut self, msg: &PoseStamped, rs: &RobotStateConfig) {
        let parent = if msg.header.frame_id.is_empty() {
            rs.world_frame.clone()
        } else {
            msg.header.frame_id.clone()
        };
        let p = msg.pose.position;
        let t = TransformStamped {
            header: Header {
                stamp: msg.header.stamp,
                frame_id: parent,
            },
            child_frame_id: rs.body_frame.clone(),
            transform: Transform {
                translation: MsgVector3 {
                    x: p.x,
                    y: p.y,
                    z: p.z,
                },
                rotation: msg.pose.orientation,
            },
        };
        self.insert(
            &TfMessage {
                transforms: vec![t],
            },
            false,
        );
    }

    /// Notes a JointState's stamp: a frame's history is kept relative to it as well, so that a
    /// pose stamped far ahead of the joint states (a wrong clock) cannot push every true pose
    /// out of it.
    pub fn saw_joint_state(&mut self, stamp_ns: i64) {
        self.newest_joint_ns = Some(self.newest_joint_ns.map_or(stamp_ns, |n| n.max(stamp_ns)));
    }

    /// Takes every transform of a `/tf` (`fixed` false) or `/tf_static` message; an invalid
    /// one is counted and skipped. A frame's poses more than two seconds older than both its
    /// newest pose and the newest joint state are dropped.
    pub fn insert(&mut self, msg: &TfMessage, fixed: bool) {
        self.memo.get_mut().clear();
        self.memo_next.set(0);
        for t in &msg.transforms {
            let (parent, child) = (
                frame_name(&t.header.frame_id),
                frame_name(&t.child_frame_id),
            );
            let stamp = t.header.stamp;
            let stamp = stamp.is_valid().then(|| stamp.to_nanos());
            let (Some(pose), Some(stamp)) = (isometry(t), stamp) else {
                self.invalid += 1;
                continue;
            };
            if parent.is_empty() || child.is_empty() || parent == child {
                self.invalid += 1;
                continue;
            }
            let known = (self.known(parent), self.known(child));
            let new_frames = usize::from(known.0.is_none()) + usize::from(known.1.is_none());
            if self.links.len() + new_frames > MAX_FRAMES {
                self.invalid += 1;
                continue;
            }
            let parent = known.0.unwrap_or_else(|| self.frame(parent));
            let child = known.1.unwrap_or_else(|| self.frame(child));
            let link = self.links[child.0].get_or_insert_with(|| Link {
                parent,
                fixed: None,
                poses: VecDeque::new(),
            });
            if link.parent != parent {
                // Re-parented: its history was in another frame.
                link.parent = parent;
                link.fixed = None;
                link.poses.clear();
            }
            if fixed {
                link.fixed = Some(pose);
                continue;
            }
            // Kept in stamp order; a late one is put in its place.
            let at = at_or_before(&link.poses, stamp);
            if at > 0 && link.poses[at - 1].0 == stamp {
                link.poses[at - 1].1 = pose;
            } else {
                link.poses.insert(at, (stamp, pose));
            }
            let newest_pose = link.poses.back().map_or(stamp, |p| p.0);
            let newest = self
                .newest_joint_ns
                .map_or(newest_pose, |j| j.min(newest_pose));
            while link.poses.len() > MAX_POSES_PER_FRAME
                || link
                    .poses
                    .front()
                    .is_some_and(|p| p.0 < newest - HISTORY_NS)
            {
                link.poses.pop_front();
            }
        }
    }

    /// A link's pose at `stamp`: interpolated between the poses around it, or the nearest
    /// within `max_age_ns`.
    fn link_at(link: &Link, stamp: i64, max_age_ns: i64) -> Result<Isometry3<f64>, NoState> {
        if let Some(f) = link.fixed {
            return Ok(f);
        }
        let at = at_or_before(&link.poses, stamp);
        let before = at.checked_sub(1).map(|i| link.poses[i]);
        let after = link.poses.get(at).copied();
        match (before, after) {
            (Some((s0, p0)), Some((s1, p1))) => {
                if s1 - s0 > 2 * max_age_ns && stamp - s0 > max_age_ns && s1 - stamp > max_age_ns {
                    return Err(NoState::Stale);
                }
                let t = (stamp - s0) as f64 / (s1 - s0) as f64;
                Ok(interpolate(&p0, &p1, t))
            }
            (Some((s, p)), None) => {
                if stamp - s > max_age_ns {
                    return Err(NoState::Stale);
                }
                // Past the newest transform (a JointState that came before the /tf of its
                // stamp, as robot_state_publisher sends them): the translation goes on at the
                // velocity of the last two transforms, on their own timeline, so that the
                // message order does not change the hip's place or velocity; the rotation is
                // held.
                match at.checked_sub(2).map(|i| link.poses[i]) {
                    Some((s0, p0)) if s > s0 && stamp > s => {
                        let k = (stamp - s) as f64 / (s - s0) as f64;
                        let moved = (p.translation.vector - p0.translation.vector) * k;
                        Ok(Isometry3::from_parts(
                            (p.translation.vector + moved).into(),
                            p.rotation,
                        ))
                    }
                    _ => Ok(p),
                }
            }
            (None, Some((s, p))) => {
                if (s - stamp).abs() <= max_age_ns {
                    Ok(p)
                } else {
                    Err(NoState::Stale)
                }
            }
            (None, None) => Err(NoState::Unknown),
        }
    }

    /// The pose of `child` in `world` at `stamp`, through every frame between them.
    pub fn lookup(
        &self,
        world: FrameId,
        child: FrameId,
        stamp: i64,
        max_age_ns: i64,
    ) -> Result<Isometry3<f64>, NoState> {
        let mut id = child;
        // `pose` takes `child`'s coordinates into `id`'s (`None`: the identity, not multiplied).
        let mut pose: Option<Isometry3<f64>> = None;
        // The first frame above `child`, and `child` in it: its world pose is remembered.
        let mut above: Option<(FrameId, Isometry3<f64>)> = None;
        // `above`'s coordinates into `id`'s, once `id` is past it (`None`: the identity).
        let mut above_pose: Option<Isometry3<f64>> = None;
        for _ in 0..MAX_DEPTH {
            if id == world {
                if let Some((frame, _)) = above {
                    let above_in_world = above_pose.unwrap_or_else(Isometry3::identity);
                    self.remember(world, frame, stamp, max_age_ns, above_in_world);
                }
                return Ok(pose.unwrap_or_else(Isometry3::identity));
            }
            if let Some((_, child_in_above)) = above
                && let Some(known) = self.remembered(world, id, stamp, max_age_ns)
            {
                return Ok(known * child_in_above);
            }
            let link = self
                .links
                .get(id.0)
                .and_then(Option::as_ref)
                .ok_or(NoState::Unknown)?;
            let step = Self::link_at(link, stamp, max_age_ns)?;
            if above.is_some() {
                above_pose = Some(above_pose.map_or(step, |p| step * p));
            }
            let to_parent = pose.map_or(step, |p| step * p);
            pose = Some(to_parent);
            id = link.parent;
            if above.is_none() && id != world {
                above = Some((id, to_parent));
            }
        }
        Err(NoState::Unknown)
    }

    fn remembered(
        &self,
        world: FrameId,
        frame: FrameId,
        stamp: i64,
        max_age_ns: i64,
    ) -> Option<Isometry3<f64>> {
        // Newest first: the legs of one JointState ask for the stamps just remembered.
        let memo = self.memo.borrow();
        // Full, the entries before `memo_next` were written last, the newest just before it.
        let split = if memo.len() < MEMO_ENTRIES {
            memo.len()
        } else {
            self.memo_next.get()
        };
        let (recent, earlier) = memo.split_at(split);
        recent
            .iter()
            .rev()
            .chain(earlier.iter().rev())
            .find(|e| {
                e.stamp == stamp
                    && e.frame == frame
                    && e.world == world
                    && e.max_age_ns == max_age_ns
            })
            .map(|e| e.pose)
    }

    /// Remembers `frame`'s pose in `world` at `stamp` (looked up with `max_age_ns`).
    fn remember(
        &self,
        world: FrameId,
        frame: FrameId,
        stamp: i64,
        max_age_ns: i64,
        pose: Isometry3<f64>,
    ) {
        let entry = MemoEntry {
            world,
            frame,
            stamp,
            max_age_ns,
            pose,
        };
        let mut memo = self.memo.borrow_mut();
        if memo.len() < MEMO_ENTRIES {
            memo.push(entry);
        } else {
            // Full: the oldest entry is overwritten in place.
            let oldest = self.memo_next.get();
            memo[oldest] = entry;
            self.memo_next.set((oldest + 1) % MEMO_ENTRIES);
        }
    }

    /// [`TfTree::hip_motion_of`] by frame names (`hip_frame`, and `cfg.world_frame`); a name
    /// the tree has never seen is [`NoState::Unknown`].
    pub fn hip_motion(
        &self,
        cfg: &RobotStateConfig,
        hip_frame: &str,
        stamp: i64,
        omega_rad_s: f64,
    ) -> Result<HipMotion, NoState> {
        let (Some(world), Some(hip)) = (self.known(&cfg.world_frame), self.known(hip_frame)) else {
            return Err(NoState::Unknown);
        };
        self.hip_motion_of(cfg, world, hip, stamp, omega_rad_s)
    }

    /// The hip of frame `hip` at `stamp` as the model takes it: its height above the surface
    /// plane (`cfg.surface_height_m` in `world`, which is `cfg.world_frame`'s number), the
    /// body's pitch, its forward, lateral (to the left of the forward) and vertical velocity
    /// (from its pose 20 ms before, when the tree has it; else zero), and the leg's rotation rate
    /// `omega_rad_s` passed through.
    pub fn hip_motion_of(
        &self,
        cfg: &RobotStateConfig,
        world: FrameId,
        hip: FrameId,
        stamp: i64,
        omega_rad_s: f64,
    ) -> Result<HipMotion, NoState> {
        let max_age = (cfg.max_age_s * 1e9) as i64;
        let pose = self.lookup(world, hip, stamp, max_age)?;
        let p = pose.translation.vector;
        // The hip frame's x axis in the world: the rotation matrix's first column, from the
        // unit quaternion.
        let q = pose.rotation.quaternion();
        let x = Vector3::new(
            1.0 - 2.0 * (q.j * q.j + q.k * q.k),
            2.0 * (q.i * q.j + q.w * q.k),
            2.0 * (q.i * q.k - q.w * q.j),
        );
        // The pitch of roll-pitch-yaw (as `euler_angles` gives it): -asin of the matrix's (2, 0).
        let pitch = -x.z.clamp(-1.0, 1.0).asin();
        // The robot's forward: the hip frame's x, horizontal.
        let horizontal_norm = (x.x * x.x + x.y * x.y).sqrt();
        let forward = if horizontal_norm > 1e-9 {
            Vector3::new(x.x / horizontal_norm, x.y / horizontal_norm, 0.0)
        } else {
            Vector3::zeros()
        };
        let velocity = self
            .lookup(world, hip, stamp - VELOCITY_SPAN_NS, max_age)
            .map(|before| (p - before.translation.vector) / (VELOCITY_SPAN_NS as f64 * 1e-9))
            .unwrap_or_else(|_| Vector3::zeros());
        let hip = HipMotion {
            height_m: p.z - cfg.surface_height_m,
            pitch_rad: pitch,
            omega_rad_s,
            forward_m_s: velocity.dot(&forward),
            up_m_s: velocity.z,
            forward_position_m: p.dot(&forward),
            // The forward's left, horizontal: z x forward.
            lateral_m_s: velocity.dot(&Vector3::new(-forward.y, forward.x, 0.0)),
        };
        if plausible_hip(&hip) {
            Ok(hip)
        } else {
            Err(NoState::Invalid)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{Header, Quaternion as Q, Time, Transform, Vector3 as V};

    fn tf(parent: &str, child: &str, t_ns: i64, xyz: [f64; 3], pitch_rad: f64) -> TransformStamped {
        let q = UnitQuaternion::from_euler_angles(0.0, pitch_rad, 0.0);
        TransformStamped {
            header: Header {
                stamp: Time::from_nanos(t_ns).unwrap(),
                frame_id: parent.into(),
            },
            child_frame_id: child.into(),
            transform: Transform {
                translation: V {
                    x: xyz[0],
                    y: xyz[1],
                    z: xyz[2],
                },
                rotation: Q {
                    x: q.i,
                    y: q.j,
                    z: q.k,
                    w: q.w,
                },
            },
        }
    }

    fn cfg() -> RobotStateConfig {
        RobotStateConfig {
            world_frame: "odom".into(),
            surface_height_m: 0.01,
            max_age_s: 0.05,
            ..RobotStateConfig::default()
        }
    }

    #[test]
    fn a_hip_below_a_moving_body_is_interpolated_through_the_chain() {
        let mut tree = TfTree::default();
        // The body heaves from 0.20 to 0.22 m and moves 1 cm forward and 5 mm to its left in
        // 100 ms; the hip is fixed 0.1 m ahead of it and 0.05 m below.
        tree.insert(
            &TfMessage {
                transforms: vec![tf("base_link", "fl_hip", 0, [0.1, 0.0, -0.05], 0.0)],
            },
            true,
        );
        for (t, z, x, y) in [(0, 0.20, 0.0, 0.0), (100_000_000, 0.22, 0.01, 0.005)] {
            tree.insert(
                &TfMessage {
                    transforms: vec![tf("/odom", "base_link", t, [x, y, z], 0.0)],
                },
                false,
            );
        }
        let hip = tree.hip_motion(&cfg(), "fl_hip", 50_000_000, 2.0).unwrap();
        assert!(
            (hip.height_m - (0.21 - 0.05 - 0.01)).abs() < 1e-12,
            "{hip:?}"
        );
        assert!((hip.up_m_s - 0.2).abs() < 1e-9, "{hip:?}");
        assert!((hip.forward_m_s - 0.1).abs() < 1e-9, "{hip:?}");
        assert!((hip.lateral_m_s - 0.05).abs() < 1e-9, "{hip:?}");
        assert_eq!(hip.omega_rad_s, 2.0);
        // Past the newest pose by more than max_age: stale; a frame nobody sent: unknown.
        assert_eq!(
            tree.hip_motion(&cfg(), "fl_hip", 200_000_000, 0.0),
            Err(NoState::Stale)
        );
        assert_eq!(
            tree.hip_motion(&cfg(), "fr_hip", 50_000_000, 0.0),
            Err(NoState::Unknown)
        );
    }

    #[test]
    fn the_body_pitch_is_the_hip_frame_pitch_in_the_world() {
        let mut tree = TfTree::default();
        let pitch = 5f64.to_radians();
        tree.insert(
            &TfMessage {
                transforms: vec![
                    tf("odom", "base_link", 0, [0.0, 0.0, 0.3], pitch),
                    tf("base_link", "fl_hip", 0, [0.2, 0.0, 0.0], 0.0),
                ],
            },
            false,
        );
        let hip = tree.hip_motion(&cfg(), "fl_hip", 0, 0.0).unwrap();
        assert!((hip.pitch_rad - pitch).abs() < 1e-12);
        // Pitched nose down by 5 deg, a hip 0.2 m ahead sits 0.2 sin 5 deg lower.
        assert!((hip.height_m - (0.3 - 0.2 * pitch.sin() - 0.01)).abs() < 1e-12);
    }

    #[test]
    fn a_pose_from_the_future_leaves_the_history_and_one_from_long_ago_is_stale() {
        let mut tree = TfTree::default();
        let sec = 1_000_000_000i64;
        tree.saw_joint_state(10 * sec);
        let at = |t: i64, z: f64| TfMessage {
            transforms: vec![tf("odom", "fl_hip", t, [0.0, 0.0, z], 0.0)],
        };
        tree.insert(&at(10 * sec, 0.2), false);
        // A year ahead (a wrong clock): kept, but the true poses stay beside it.
        tree.insert(&at(10 * sec + 365 * 86_400 * sec, 0.5), false);
        tree.insert(&at(10 * sec + sec / 100, 0.2), false);
        let hip = tree.hip_motion(&cfg(), "fl_hip", 10 * sec, 0.0).unwrap();
        assert!((hip.height_m - (0.2 - 0.01)).abs() < 1e-12, "{hip:?}");
        // A joint state an hour after the last pose: stale, not the old height.
        assert_eq!(
            tree.hip_motion(&cfg(), "fl_hip", 3600 * sec, 0.0),
            Err(NoState::Stale)
        );
        // A pose from long ago does not displace the recent ones.
        tree.insert(&at(sec, 0.9), false);
        let hip = tree.hip_motion(&cfg(), "fl_hip", 10 * sec, 0.0).unwrap();
        assert!((hip.height_m - (0.2 - 0.01)).abs() < 1e-12, "{hip:?}");
    }

    #[test]
    fn a_frame_numbered_before_any_transform_is_found_once_one_comes() {
        let mut tree = TfTree::default();
        let (world, hip) = (tree.frame("/odom"), tree.frame("fl_hip"));
        assert_eq!(tree.frame("odom"), world);
        assert_eq!(
            tree.hip_motion_of(&cfg(), world, hip, 0, 0.0),
            Err(NoState::Unknown)
        );
        tree.insert(
            &TfMessage {
                transforms: vec![tf("odom", "fl_hip", 0, [0.0, 0.0, 0.2], 0.0)],
            },
            false,
        );
        let by_number = tree.hip_motion_of(&cfg(), world, hip, 0, 0.0).unwrap();
        assert_eq!(Ok(by_number), tree.hip_motion(&cfg(), "/fl_hip", 0, 0.0));
        assert!((by_number.height_m - (0.2 - 0.01)).abs() < 1e-12);
    }

    #[test]
    fn a_flood_of_new_frame_names_is_counted_not_kept() {
        let mut tree = TfTree::default();
        let hip = tree.frame("fl_hip");
        for k in 0..MAX_FRAMES + 10 {
            tree.insert(
                &TfMessage {
                    transforms: vec![tf("odom", &format!("junk_{k}"), 0, [0.0; 3], 0.0)],
                },
                false,
            );
        }
        assert_eq!(tree.links.len(), MAX_FRAMES);
        assert_eq!(
            tree.invalid, 12,
            "two frames taken before the flood: hip and odom"
        );
        // Frames already known still take transforms.
        tree.insert(
            &TfMessage {
                transforms: vec![tf("odom", "fl_hip", 0, [0.0, 0.0, 0.2], 0.0)],
            },
            false,
        );
        let world = tree.frame("odom");
        assert!(tree.hip_motion_of(&cfg(), world, hip, 0, 0.0).is_ok());
    }

    #[test]
    fn invalid_transforms_are_counted_and_skipped() {
        let mut tree = TfTree::default();
        let mut bad = tf("odom", "fl_hip", 0, [f64::NAN, 0.0, 0.1], 0.0);
        let mut zero = tf("odom", "fl_hip", 0, [0.0, 0.0, 0.1], 0.0);
        zero.transform.rotation = Q {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 0.0,
        };
        bad.header.frame_id = "odom".into();
        let own_parent = tf("fl_hip", "fl_hip", 0, [0.0, 0.0, 0.1], 0.0);
        tree.insert(
            &TfMessage {
                transforms: vec![bad, zero, own_parent],
            },
            false,
        );
        assert_eq!(tree.invalid, 3);
        assert_eq!(
            tree.hip_motion(&cfg(), "fl_hip", 0, 0.0),
            Err(NoState::Unknown)
        );
    }

    #[test]
    fn a_small_turn_is_interpolated_as_slerp_does_and_a_large_one_by_slerp() {
        let pose = |pitch: f64, yaw: f64| {
            Isometry3::from_parts(
                Translation3::new(0.1, -0.2, 0.3),
                UnitQuaternion::from_euler_angles(0.2, pitch, yaw),
            )
        };
        // Up to a degree apart, and one of them given as -q (the same rotation).
        for (a, b) in [(0.0, 0.9f64.to_radians()), (0.3, 0.3 + 1e-4), (-0.1, -0.1)] {
            let (p0, mut p1) = (pose(a, 0.1), pose(b, 0.1 + 1e-3));
            for flip in [false, true] {
                if flip {
                    p1.rotation = UnitQuaternion::new_unchecked(-p1.rotation.into_inner());
                }
                for t in [0.0, 0.1, 0.25, 0.5, 0.8, 1.0] {
                    let ours = interpolate(&p0, &p1, t);
                    let tf2 = p0.lerp_slerp(&p1, t);
                    assert!(ours.rotation.angle_to(&tf2.rotation) < 1e-7, "{a} {b} {t}");
                    assert!((ours.translation.vector - tf2.translation.vector).norm() < 1e-15);
                }
            }
        }
        // Further apart: slerp itself.
        let (p0, p1) = (pose(0.0, 0.0), pose(0.5, 0.2));
        assert_eq!(interpolate(&p0, &p1, 0.3), p0.lerp_slerp(&p1, 0.3));
    }

    #[test]
    fn remembered_poses_give_what_a_walk_through_the_tree_gives() {
        // Two trees alike; the second forgets what it remembered before every lookup.
        let (mut fast, mut walked) = (TfTree::default(), TfTree::default());
        for tree in [&mut fast, &mut walked] {
            tree.insert(
                &TfMessage {
                    transforms: (0..3)
                        .map(|i| {
                            tf(
                                "base_link",
                                &format!("hip{i}"),
                                0,
                                [0.1 * i as f64, 0.05, -0.02],
                                0.1,
                            )
                        })
                        .collect(),
                },
                true,
            );
            for k in 0..50i64 {
                let ph = k as f64 * 0.1;
                tree.insert(
                    &TfMessage {
                        transforms: vec![tf(
                            "odom",
                            "base_link",
                            k * 2_000_000,
                            [0.01 * ph, 0.0, 0.2 + 0.01 * ph.sin()],
                            0.05 * ph.cos(),
                        )],
                    },
                    false,
                );
            }
        }
        let world = fast.frame("odom");
        let hips: Vec<_> = (0..3).map(|i| fast.frame(&format!("hip{i}"))).collect();
        // More stamps than the memory holds, each asked for by every hip, and the stamps revisited.
        for round in 0..2 {
            for k in 0..12i64 {
                let stamp = 20_000_000 + k * 1_300_000 + round;
                for (i, &hip) in hips.iter().enumerate() {
                    let got = fast.hip_motion_of(&cfg(), world, hip, stamp, 0.0);
                    walked.insert(&TfMessage::default(), false);
                    let want = walked.hip_motion(&cfg(), &format!("hip{i}"), stamp, 0.0);
                    assert_eq!(got, want, "hip {i} at {stamp}");
                }
            }
        }
    }

    #[test]
    fn poses_are_counted_from_the_newest_as_a_binary_search_counts_them() {
        let pose = Isometry3::identity();
        for n in [0usize, 1, 2, 3, 7, 100, 1000] {
            // Stamps 10, 20, ... with a run of equal ones.
            let poses: VecDeque<(i64, Isometry3<f64>)> = (0..n as i64)
                .map(|k| (if (4..7).contains(&k) { 40 } else { 10 * k }, pose))
                .collect();
            for stamp in -5..(10 * n as i64 + 15) {
                assert_eq!(
                    at_or_before(&poses, stamp),
                    poses.partition_point(|(s, _)| *s <= stamp),
                    "{n} poses, stamp {stamp}"
                );
            }
        }
    }
}
