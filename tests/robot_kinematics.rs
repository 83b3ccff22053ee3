//! The PSM URDF against the dVRK modified-DH table, the Jacobian against finite differences, and
//! IK∘FK round trips, at pseudo-random joint vectors inside the limits.

use dvrk_tissue_sim::robot::dh;
use dvrk_tissue_sim::robot::ecm::ECM_JOINT_NAMES;
use dvrk_tissue_sim::robot::psm::RCM_MIN_DISTANCE;
use dvrk_tissue_sim::robot::{ArmKind, IkError, Psm, RcmPolicy};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// SplitMix64: deterministic, so a failure reproduces.
struct Rng(u64);

impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    fn uniform(&mut self, lower: f64, upper: f64) -> f64 {
        lower + (upper - lower) * self.next_f64()
    }

    /// A joint vector inside the PSM limits, shrunk by `margin` of each range at both ends.
    fn joints(&mut self, psm: &Psm, margin: f64) -> [f64; 6] {
        let joints = psm.joints().joints();
        std::array::from_fn(|i| {
            let (lower, upper) = (joints[i].lower, joints[i].upper);
            let pad = margin * (upper - lower);
            self.uniform(lower + pad, upper - pad)
        })
    }
}

fn assert_same_pose(a: &Isometry3<f64>, b: &Isometry3<f64>, tolerance: f64, context: &str) {
    let dp = (a.translation.vector - b.translation.vector).norm();
    let dr = a.rotation.angle_to(&b.rotation);
    assert!(
        dp <= tolerance && dr <= tolerance,
        "{context}: {dp:e} m, {dr:e} rad apart"
    );
}

#[test]
fn urdf_chain_matches_modified_dh_at_random_joints() {
    let psm = Psm::classic("PSM1").unwrap();
    let mut rng = Rng(1);
    for sample in 0..2000 {
        let q = rng.joints(&psm, 0.0);
        let dh_frames = dh::forward(&dh::PSM_LARGE_NEEDLE_DRIVER, &q);
        // Link poses: base, the six DH frames, then the tool frame.
        let poses = psm.chain().link_poses(&q).unwrap();
        assert_eq!(poses.len(), 8);
        for (i, dh_frame) in dh_frames.iter().enumerate() {
            assert_same_pose(
                &poses[i + 1],
                dh_frame,
                1e-9,
                &format!("sample {sample} frame {}", i + 1),
            );
        }
        let tool = psm.forward(&q).unwrap();
        assert_same_pose(
            &tool,
            &dh::psm_tool_pose(&q),
            1e-9,
            &format!("sample {sample} tool"),
        );
        assert_eq!(poses[7], tool);
    }
}

#[test]
fn urdf_chain_matches_dh_at_the_joint_limits() {
    let psm = Psm::classic("PSM1").unwrap();
    let joints = psm.joints().joints().to_vec();
    for corner in 0..64u32 {
        let q: [f64; 6] = std::array::from_fn(|i| {
            if corner & (1 << i) == 0 {
                joints[i].lower
            } else {
                joints[i].upper
            }
        });
        assert_same_pose(
            &psm.forward(&q).unwrap(),
            &dh::psm_tool_pose(&q),
            1e-9,
            &format!("corner {q:?}"),
        );
    }
}

#[test]
fn jacobian_matches_finite_differences_of_forward_kinematics() {
    let psm = Psm::classic("PSM1").unwrap();
    let mut rng = Rng(2);
    let h = 1e-6;
    for sample in 0..200 {
        let q = rng.joints(&psm, 0.01);
        let jacobian = psm.jacobian(&q).unwrap();
        let pose = psm.forward(&q).unwrap();
        for j in 0..6 {
            let mut plus = q;
            let mut minus = q;
            plus[j] += h;
            minus[j] -= h;
            let (p_plus, p_minus) = (psm.forward(&plus).unwrap(), psm.forward(&minus).unwrap());
            let linear = (p_plus.translation.vector - p_minus.translation.vector) / (2.0 * h);
            // Angular velocity: the rotation vector of R(q+h)·R(q−h)ᵀ over 2h, in the base frame.
            let angular = (p_plus.rotation * p_minus.rotation.inverse()).scaled_axis() / (2.0 * h);
            let column = jacobian.column(j);
            let linear_error = (column.fixed_rows::<3>(0) - linear).norm();
            let angular_error = (column.fixed_rows::<3>(3) - angular).norm();
            assert!(
                linear_error < 1e-8 && angular_error < 1e-8,
                "sample {sample} joint {j}: {linear_error:e} m/unit, {angular_error:e} rad/unit \
                 at {q:?} (tool at {:?})",
                pose.translation.vector
            );
        }
    }
}

#[test]
fn ik_recovers_random_reachable_poses_from_a_nearby_start() {
    let psm = Psm::classic("PSM1").unwrap();
    let options = *psm.ik_options();
    let mut rng = Rng(3);
    let mut solved = 0;
    for sample in 0..500 {
        let q = rng.joints(&psm, 0.02);
        let target = psm.forward(&q).unwrap();
        if target.translation.vector.norm() < RCM_MIN_DISTANCE {
            continue;
        }
        // Warm start as a servo loop would: the arm is near, not at, the answer.
        let mut start: [f64; 6] = std::array::from_fn(|i| {
            let reach = if i == 2 { 0.01 } else { 0.2 };
            q[i] + rng.uniform(-reach, reach)
        });
        psm.joints().clamp(&mut start);
        let solution = psm
            .solve_cartesian(&target, &start, RcmPolicy::Reject)
            .unwrap_or_else(|e| panic!("sample {sample}: {e} (q {q:?}, start {start:?})"));
        assert!(solution.target.clamped_from.is_none());
        let reached = psm.forward(&solution.ik.q).unwrap();
        assert_same_pose(
            &reached,
            &target,
            options.position_tolerance,
            &format!("sample {sample}"),
        );
        assert!(solution.ik.position_error <= options.position_tolerance);
        assert!(solution.ik.orientation_error <= options.orientation_tolerance);
        psm.joints()
            .validate::<&str>(&[], &solution.ik.q, None)
            .unwrap();
        solved += 1;
    }
    assert!(solved > 400, "only {solved} reachable samples");
}

#[test]
fn ik_recovers_random_poses_from_the_home_pose() {
    // Far starts: IK from dVRK simulators' start pose (insertion 0.12 m, everything else 0) to
    // poses in the middle of the workspace.
    let psm = Psm::classic("PSM1").unwrap();
    let home = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0];
    let mut rng = Rng(4);
    for sample in 0..200 {
        let q = [
            rng.uniform(-0.8, 0.8),
            rng.uniform(-0.6, 0.6),
            rng.uniform(0.06, 0.22),
            rng.uniform(-1.5, 1.5),
            rng.uniform(-0.8, 0.8),
            rng.uniform(-0.8, 0.8),
        ];
        let target = psm.forward(&q).unwrap();
        let solution = psm
            .solve_cartesian(&target, &home, RcmPolicy::Reject)
            .unwrap_or_else(|e| panic!("sample {sample}: {e} (q {q:?})"));
        let reached = psm.forward(&solution.ik.q).unwrap();
        assert_same_pose(&reached, &target, 1e-6, &format!("sample {sample}"));
    }
}

#[test]
fn ik_reports_unreachable_targets_with_the_best_effort() {
    let psm = Psm::classic("PSM1").unwrap();
    let home = [0.0, 0.0, 0.12, 0.0, 0.0, 0.0];
    // 0.5 m from the RCM: past the 0.24 m insertion travel.
    let far = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, -0.5),
        psm.forward(&home).unwrap().rotation,
    );
    match psm.solve_cartesian(&far, &home, RcmPolicy::Reject) {
        Err(dvrk_tissue_sim::robot::PsmError::Ik(IkError::NotConverged {
            position_error,
            best,
            ..
        })) => {
            // The best effort is full insertion, straight down: 0.5 − (0.24 − 0.0065) m short.
            assert!(
                (position_error - (0.5 - 0.2335)).abs() < 1e-3,
                "{position_error}"
            );
            assert!((best[2] - 0.24).abs() < 1e-9);
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
    let start_nan = [f64::NAN, 0.0, 0.12, 0.0, 0.0, 0.0];
    assert!(matches!(
        psm.solve_cartesian(&psm.forward(&home).unwrap(), &start_nan, RcmPolicy::Reject),
        Err(dvrk_tissue_sim::robot::PsmError::Ik(
            IkError::NonFiniteStart
        ))
    ));
    let tilted = Isometry3::from_parts(
        Translation3::from(Vector3::new(0.0, 0.0, -0.1)),
        UnitQuaternion::identity(),
    );
    // Tool z along +z while the tool sits below the RCM: the wrist cannot turn that far back.
    assert!(psm
        .solve_cartesian(&tilted, &home, RcmPolicy::Reject)
        .is_err());
}

/// A PSM URDF in dvrk_model's layout (tests/urdf: written for these tests from the names
/// dvrk_model uses and the DH table), loaded as arm `name`.
fn dvrk_model_psm(file: &str, name: &str) -> Psm {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/urdf")
        .join(file);
    Psm::from_urdf_file(&path, name).unwrap_or_else(|e| panic!("{file} as {name}: {e}"))
}

/// The largest distance (m) and angle (rad) between `psm`'s tool frame and the built-in URDF's
/// and the DH table's over `samples` random joint vectors inside `psm`'s limits.
fn tool_frame_disagreement(psm: &Psm, samples: usize) -> (f64, f64) {
    let classic = Psm::classic("PSM1").unwrap();
    let mut rng = Rng(7);
    let (mut dp, mut dr) = (0.0f64, 0.0f64);
    for _ in 0..samples {
        let q = rng.joints(psm, 0.0);
        let tool = psm.forward(&q).unwrap();
        for reference in [classic.forward(&q).unwrap(), dh::psm_tool_pose(&q)] {
            dp = dp.max((tool.translation.vector - reference.translation.vector).norm());
            dr = dr.max(tool.rotation.angle_to(&reference.rotation));
        }
    }
    (dp, dr)
}

#[test]
fn dvrk_model_layouts_give_the_dh_tool_frame() {
    for (file, name) in [
        ("PSM1_current_layout.urdf", "PSM1"),
        ("PSM1_current_layout.urdf", "PSM3"),
        ("PSM2_current_layout.urdf", "PSM2"),
        ("PSM2_current_layout.urdf", "PSM1"),
        ("PSM1_older_layout.urdf", "PSM1"),
        ("PSM1_older_layout.urdf", "PSM2"),
    ] {
        let psm = dvrk_model_psm(file, name);
        assert_eq!(psm.base_frame(), format!("{name}_base"));
        assert_eq!(psm.chain().tip_link(), name);
        let frames = psm
            .link_frames(&[0.1, 0.2, 0.1, 0.3, 0.2, 0.1], 0.4)
            .unwrap();
        let jaw_1 = frames
            .iter()
            .find(|f| f.link.ends_with("jaw_1_link") || f.link.ends_with("ee_link_1"));
        assert!(jaw_1.is_some(), "{file}: no jaw_1 frame");
        assert!(
            frames.iter().all(|f| f.link.starts_with(name)),
            "{file} as {name}"
        );
        let (dp, dr) = tool_frame_disagreement(&psm, 2000);
        println!("{file} as {name}: tool frame within {dp:.3e} m, {dr:.3e} rad of DH and psm.urdf");
        assert!(
            dp < 1e-6 && dr < 1e-6,
            "{file} as {name}: {dp:e} m, {dr:e} rad"
        );
    }
}

/// A `.urdf.xacro` in dvrk_model's package layout, expanded by PyPI's xacro (the venv
/// `.ci/run` makes) with `$(find dvrk_model)` resolved through the scene's `dvrk_model`
/// folder: the arm it describes has the DH tool frame.
#[test]
fn a_dvrk_model_xacro_expands_with_pypi_xacro_and_gives_the_dh_tool_frame() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let xacro = root.join(".venv/bin/xacro");
    if !xacro.exists() {
        let reason = format!("{} is not installed (.ci/run installs it)", xacro.display());
        assert!(std::env::var_os("CI").is_none(), "CI is set but {reason}");
        eprintln!("SKIPPED: {reason}");
        return;
    }
    let text = dvrk_tissue_sim::robot::urdf::expand_xacro(
        xacro.to_str().unwrap(),
        &root.join("tests/urdf/PSM1.urdf.xacro"),
        Some(&root.join("tests/urdf/dvrk_model")),
    )
    .unwrap();
    let robot = dvrk_tissue_sim::robot::urdf::parse_urdf(&text).unwrap();
    let psm = Psm::from_urdf(robot, "PSM1").unwrap();
    let (dp, dr) = tool_frame_disagreement(&psm, 500);
    println!("expanded xacro: tool frame within {dp:.3e} m, {dr:.3e} rad of DH and psm.urdf");
    assert!(dp < 1e-6 && dr < 1e-6, "{dp:e} m, {dr:e} rad");
    // Without the package folder, ROS 2's xacro cannot resolve $(find dvrk_model).
    let unresolved = dvrk_tissue_sim::robot::urdf::expand_xacro(
        xacro.to_str().unwrap(),
        &root.join("tests/urdf/PSM1.urdf.xacro"),
        None,
    );
    assert!(unresolved.is_err());
}

/// The Si PSM fixture (tests/urdf/PSM1_si_layout.urdf: dvrk_model's Si layout, with the RCM link
/// above a base link 0.78 m away and the parallelogram in the chain) as PSM1, PSM2 and PSM3:
/// the RCM is the base, the jaws are found, the limits are the file's (dVRK's Si values), the
/// speeds dVRK's, and the tool frame is the Si DH table's (PSM_Si.json + the 420006 tool).
#[test]
fn si_layout_gives_the_si_dh_tool_frame() {
    for name in ["PSM1", "PSM2", "PSM3"] {
        let psm = dvrk_model_psm("PSM1_si_layout.urdf", name);
        assert_eq!(psm.base_frame(), format!("{name}_base"));
        assert_eq!(psm.chain().link_names()[0], format!("{name}_RCM_link"));
        assert_eq!(psm.chain().tip_link(), name);
        let frames = psm
            .link_frames(&[0.1, 0.2, 0.1, 0.3, 0.2, 0.1], 0.4)
            .unwrap();
        for jaw in ["_jaw_link", "_jaw_1_link", "_jaw_2_link"] {
            assert!(
                frames.iter().any(|f| f.link == format!("{name}{jaw}")),
                "{name}: no {jaw} frame"
            );
        }
        let limits = [psm.joints().limits(), psm.jaw().limits()].concat();
        assert_eq!(
            limits,
            [
                (-2.964, 2.964),
                (-1.265, 1.301),
                (0.0, 0.29),
                (-4.53786, 4.53786),
                (-1.39626, 1.39626),
                (-1.39626, 1.39626),
                (-0.349066, 1.39626),
            ]
        );
        assert_eq!(
            psm.joints().max_velocities(),
            dvrk_tissue_sim::robot::psm::DVRK_PSM_SPEEDS
        );

        // The tool frame, and the instrument's frames (DH frames 3..6: adaptor, roll, wrist
        // pitch, wrist yaw). The Si table differs from the Classic one at the adaptor (the
        // instrument's back end 0.4826 m behind the RCM at zero insertion against 0.4318 m);
        // from the roll on the two coincide, the Si shaft being longer by the same 50.8 mm.
        let links = [
            "_adaptor_link",
            "_roll_link",
            "_wrist_pitch_link",
            "_wrist_yaw_link",
        ];
        let mut rng = Rng(11);
        let (mut dp, mut dr, mut from_classic) = (0.0f64, 0.0f64, f64::INFINITY);
        let mut compare = |a: &Isometry3<f64>, b: &Isometry3<f64>| {
            dp = dp.max((a.translation.vector - b.translation.vector).norm());
            dr = dr.max(a.rotation.angle_to(&b.rotation));
        };
        for _ in 0..2000 {
            let q = rng.joints(&psm, 0.0);
            let tool = psm.forward(&q).unwrap();
            compare(
                &tool,
                &dh::tool_pose(&dh::PSM_SI_LARGE_NEEDLE_DRIVER_420006, &q),
            );
            let si = dh::forward(&dh::PSM_SI_LARGE_NEEDLE_DRIVER_420006, &q);
            let classic = dh::forward(&dh::PSM_LARGE_NEEDLE_DRIVER, &q);
            let frames = psm.link_frames(&q, 0.0).unwrap();
            for (suffix, (si, classic)) in links.iter().zip(si[2..].iter().zip(&classic[2..])) {
                let link = format!("{name}{suffix}");
                let frame = &frames.iter().find(|f| f.link == link).unwrap().pose;
                compare(frame, si);
                if *suffix == "_adaptor_link" {
                    from_classic = from_classic
                        .min((frame.translation.vector - classic.translation.vector).norm());
                }
            }
        }
        println!(
            "Si layout as {name}: tool and instrument frames within {dp:.3e} m, {dr:.3e} rad of \
             the Si DH table; adaptor >= {from_classic:.4} m from the Classic table's"
        );
        assert!(dp < 1e-6 && dr < 1e-6, "{name}: {dp:e} m, {dr:e} rad");
        assert!(from_classic > 0.05, "{from_classic}");
    }
}

/// The built-in ECM at joint zero: the scope points straight down from the RCM along the
/// base's −z, its tip 0.3829 − 0.3822 m past the RCM, the tool frame's z (the camera's
/// optical axis) along the scope.
#[test]
fn ecm_at_joint_zero_points_the_scope_down_through_the_rcm() {
    let ecm = Psm::classic_ecm("ECM").unwrap();
    assert_eq!(ecm.kind(), ArmKind::Ecm);
    assert_eq!(ecm.joints().names(), ECM_JOINT_NAMES);
    assert!(ecm.jaw().is_empty());
    assert_eq!(ecm.base_frame(), "ECM_base");
    let tip = ecm.forward(&[0.0; 4]).unwrap();
    let depth = 0.3829 - 0.3822;
    assert!((tip.translation.vector - Vector3::new(0.0, 0.0, -depth)).norm() < 1e-12);
    let z = tip.rotation * Vector3::z();
    assert!((z - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12, "z = {z}");
    assert_eq!(
        ecm.joints().limits(),
        [
            (-1.595183, 1.581733),
            (-0.78371, 1.157657),
            (0.0, 0.254193),
            (-1.552676, 1.566741)
        ]
    );
}

/// At known joints the URDF's tip is the DH table's, and insertion moves it along the
/// scope's axis (the optical axis) through the RCM.
#[test]
fn ecm_urdf_matches_its_dh_table_at_a_known_pose() {
    let ecm = Psm::classic_ecm("ECM").unwrap();
    let q = [0.3, -0.4, 0.1, 0.5];
    let tip = ecm.forward(&q).unwrap();
    assert_same_pose(&tip, &dh::ecm_tool_pose(&q), 1e-12, "q = {q:?}");
    // Yaw 0.3 rad about the base's x... the shaft stays on a line through the RCM whatever
    // the pose: the tip is (insertion + 0.0007 m) from it, along the optical axis.
    let z = tip.rotation * Vector3::z();
    let p = tip.translation.vector;
    assert!((p.norm() - (0.1 + 0.3829 - 0.3822)).abs() < 1e-12);
    assert!(
        (p.normalize() - z).norm() < 1e-12,
        "tip {p} not along z {z}"
    );
    let deeper = ecm.forward(&[0.3, -0.4, 0.15, 0.5]).unwrap();
    assert!((deeper.translation.vector - (p + 0.05 * z)).norm() < 1e-12);
    // The roll turns the view about the optical axis and nothing else.
    let rolled = ecm.forward(&[0.3, -0.4, 0.1, -0.5]).unwrap();
    assert!((rolled.translation.vector - p).norm() < 1e-12);
    assert!(((rolled.rotation * Vector3::z()) - z).norm() < 1e-12);
    assert!((rolled.rotation.angle_to(&tip.rotation) - 1.0).abs() < 1e-9);
    eprintln!(
        "ECM tip at q = 0: {:?}",
        ecm.forward(&[0.0; 4])
            .unwrap()
            .rotation
            .to_rotation_matrix()
    );
    eprintln!(
        "ECM tip at yaw 0.3: {:?}",
        ecm.forward(&[0.3, 0.0, 0.1, 0.0]).unwrap()
    );
    eprintln!(
        "ECM tip at pitch 0.3: {:?}",
        ecm.forward(&[0.0, 0.3, 0.1, 0.0]).unwrap()
    );
}

/// dvrk_model's current classic ECM (tests/urdf/ECM_current_layout.urdf: its RCM link the
/// root, the parallelogram as mimic joints in the chain, roll about −z, the straight scope's
/// tip `ECM_tip_link`) loads by role: the RCM is the base, the tip the tool frame, the joints
/// are published under dVRK's names with the file's limits, and it is a remote-centre
/// mechanism: over random joints the tip stays on the line through the RCM along its view
/// axis (to the file's rounding of its parallelogram), insertion slides it along that axis,
/// and the roll only turns the view about it. Its frames are the file's, not the DH
/// table's: the tip sits 10.1 mm further back along the view (printed), and yaw moves it
/// along the RCM frame's y where the DH table's moves it along x.
#[test]
fn dvrk_model_current_ecm_layout_loads_by_role_as_a_remote_centre_arm() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/urdf/ECM_current_layout.urdf");
    let text = std::fs::read_to_string(&path).unwrap();
    let robot = dvrk_tissue_sim::robot::urdf::parse_urdf(&text).unwrap();
    let ecm = Psm::ecm_from_urdf_with_roles(robot, "ECM", &Default::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(ecm.kind(), ArmKind::Ecm);
    assert_eq!(ecm.base_frame(), "ECM_base");
    assert_eq!(ecm.chain().tip_link(), "ECM_tip_link");
    assert_eq!(ecm.joints().names(), ECM_JOINT_NAMES);
    assert_eq!(
        ecm.joints().limits(),
        [
            (-1.595183, 1.581733),
            (-0.783710, 1.157657),
            (0.0, 0.254193),
            (-1.552676, 1.566741)
        ]
    );
    let mut rng = Rng(11);
    let (mut off_line, mut offsets) = (0.0f64, Vec::new());
    for _ in 0..500 {
        let q: [f64; 4] = std::array::from_fn(|i| {
            let j = &ecm.joints().joints()[i];
            rng.uniform(j.lower, j.upper)
        });
        let tip = ecm.forward(&q).unwrap();
        let (p, z) = (tip.translation.vector, tip.rotation * Vector3::z());
        off_line = off_line.max(p.cross(&z).norm());
        offsets.push(p.dot(&z) - q[2]);
        let deeper = ecm.forward(&[q[0], q[1], q[2] + 0.01, q[3]]).unwrap();
        assert!((deeper.translation.vector - (p + 0.01 * z)).norm() < 1e-9);
        let rolled = ecm.forward(&[q[0], q[1], q[2], q[3] + 0.2]).unwrap();
        assert!((rolled.translation.vector - p).norm() < 1e-9);
        assert!((rolled.rotation * Vector3::z() - z).norm() < 1e-9);
        assert!((rolled.rotation.angle_to(&tip.rotation) - 0.2).abs() < 1e-9);
    }
    let spread = offsets.iter().fold(f64::MIN, |a, &b| a.max(b))
        - offsets.iter().fold(f64::MAX, |a, &b| a.min(b));
    let dh_offset = dh::ecm_tool_pose(&[0.0; 4]).translation.vector.z.abs();
    println!(
        "dvrk_model ECM: tip within {off_line:.2e} m of the RCM's view line; tip at insertion − \
         {:.5} m along the view (DH: + {dh_offset:.5} m), spread {spread:.1e} m",
        -offsets[0]
    );
    // The file's parallelogram lengths are rounded: measured 0.12 mm off the line at most,
    // the offset along the view within 79 µm.
    assert!(off_line < 2e-4, "tip {off_line} m off the RCM's line");
    assert!(
        spread < 1e-4,
        "the tip's offset along the view varies by {spread} m"
    );
    let yawed = ecm
        .forward(&[0.3, 0.0, 0.1, 0.0])
        .unwrap()
        .translation
        .vector;
    assert!(yawed.y > 0.02 && yawed.x.abs() < 1e-9, "{yawed:?}");
}
