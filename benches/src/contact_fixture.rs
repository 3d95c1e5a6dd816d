//! Contact scenarios shared by the contact benches and the tick-budget harness: a contact
//! stage with a scripted anchor (the device-mapped pose), stepped once per call.

use devices::sim::SimulatedArmConfig;
use haptic_loop::contact::{
    Anchor, ContactConfig, ContactStage, Voxmap, VoxmapConfig, VoxmapReport,
};
use nalgebra::{Isometry3, Translation3, Vector3};
use parry3d_f64::math::Pose;
use parry3d_f64::shape::SharedShape;
use scene::Scene;

/// Where the object is relative to the scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Situation {
    /// Far from every obstacle: the whole pointshell is culled.
    Free,
    /// Hovering 2 mm above the surface: every cluster near it is tested, none penetrates.
    Near,
    /// Pushed 3 mm into the surface by the coupling, settled: a whole face in contact.
    Resting,
}

impl Situation {
    /// Short name for bench ids.
    pub fn name(self) -> &'static str {
        match self {
            Situation::Free => "free",
            Situation::Near => "near",
            Situation::Resting => "resting",
        }
    }
}

/// A contact stage and the script that moves its anchor.
pub struct Fixture {
    stage: ContactStage,
    anchor: Isometry3<f64>,
    /// Anchor velocity along y while sliding, m/s (0 = still).
    slide_m_per_s: f64,
    tick: u64,
}

impl std::fmt::Debug for Fixture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fixture")
            .field("points", &self.points())
            .finish()
    }
}

fn stage(
    obstacles: &[(Pose, SharedShape)],
    object: &[(Pose, SharedShape)],
    voxel_m: f64,
) -> ContactStage {
    let config = ContactConfig::with_voxel_m(voxel_m);
    let spec = SimulatedArmConfig::default().spec();
    ContactStage::from_shapes(obstacles, object, config, &spec, 1.0).expect("fixture builds")
}

impl Fixture {
    /// A cube whose pointshell has about `points` points at `voxel_m`, over a plate whose top
    /// face is z = 0, in `situation`.
    pub fn cube_on_plate(points: usize, voxel_m: f64, situation: Situation) -> Self {
        let half = 0.5 * voxel_m * (points as f64 / 6.0).sqrt();
        let plate = vec![(
            Pose::translation(0.0, 0.0, -0.01),
            SharedShape::cuboid(half + 0.03, half + 0.03, 0.01),
        )];
        let cube = vec![(Pose::IDENTITY, SharedShape::cuboid(half, half, half))];
        let z = match situation {
            Situation::Free => half + 0.3,
            Situation::Near => half + 0.002,
            Situation::Resting => half - 0.003,
        };
        let mut f = Self {
            stage: stage(&plate, &cube, voxel_m),
            anchor: Isometry3::translation(0.0, 0.0, z),
            slide_m_per_s: 0.0,
            tick: 0,
        };
        f.stage.place(Isometry3::translation(0.0, 0.0, z.max(half)));
        f.settle();
        f
    }

    /// The wall-hole scene's S pressed against the wall beside the hole (its stated
    /// orientation), sliding along the wall at 5 cm/s.
    pub fn s_on_wall(voxel_m: f64) -> Self {
        let scene = Scene::wall_with_hole();
        let obstacles = scene::shapes::part_shapes(&scene.obstacles);
        let object = scene::shapes::part_shapes(&scene.moving_object);
        let rotation = scene.start.rot;
        // The S's reference point 60 mm in front of the wall: part of it touches, the
        // coupling anchor 3 mm further in pushes.
        let at = |x: f64| Isometry3::from_parts(Translation3::new(x, 0.15, 0.1), rotation);
        let mut st = stage(&obstacles, &object, voxel_m);
        let touch = first_touch_x(&st, &at(-0.3));
        st.place(at(touch - 0.0005));
        let mut f = Self {
            stage: st,
            anchor: at(touch + 0.003),
            slide_m_per_s: 0.05,
            tick: 0,
        };
        f.settle();
        f
    }

    /// The wall-hole voxmap at `voxel_m`.
    pub fn wall_hole_voxmap(voxel_m: f64) -> VoxmapReport {
        let scene = Scene::wall_with_hole();
        let obstacles = scene::shapes::part_shapes(&scene.obstacles);
        let config = VoxmapConfig {
            voxel_m,
            ..VoxmapConfig::default()
        };
        *Voxmap::build(&obstacles, &config).expect("builds").report()
    }

    fn settle(&mut self) {
        for _ in 0..300 {
            self.step();
        }
    }

    /// Pointshell size.
    pub fn points(&self) -> usize {
        self.stage.model().pointshell().len()
    }

    /// One step (1 ms); returns the penetration, m.
    pub fn step(&mut self) -> f64 {
        self.tick += 1;
        // Slide back and forth over 10 cm so a long run stays on the wall.
        let phase = (self.tick % 4000) as f64 / 1000.0;
        let (dy, vy) = if phase < 2.0 {
            (phase * self.slide_m_per_s, self.slide_m_per_s)
        } else {
            ((4.0 - phase) * self.slide_m_per_s, -self.slide_m_per_s)
        };
        let mut pose = self.anchor;
        pose.translation.vector.y += dy;
        let anchor = Anchor {
            pose,
            linear_velocity: Vector3::new(0.0, vy, 0.0),
            angular_velocity: Vector3::zeros(),
        };
        self.stage.step(&anchor, 0.001).penetration_m
    }

    /// Points tested against the voxmap in the last step's situation (for reports).
    pub fn stage(&self) -> &ContactStage {
        &self.stage
    }
}

/// The x at which the object at `pose` moved along +x first touches the scene (bisection on
/// the contact probe), m.
fn first_touch_x(stage: &ContactStage, pose: &Isometry3<f64>) -> f64 {
    let at = |x: f64| {
        let mut p = *pose;
        p.translation.vector.x = x;
        stage.probe(&p).contacts > 0
    };
    let (mut lo, mut hi) = (pose.translation.vector.x, 0.0);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if at(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}
