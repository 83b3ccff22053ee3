//! dVRK's kinematics services on each simulated arm, as dVRK's Python client calls them
//! (`arm.forward_kinematics(jp)`, `arm.inverse_kinematics(jp, cp)` on `crtk_python_client`):
//! `<arm>/forward_kinematics` and `<arm>/local/forward_kinematics`
//! (`crtk_msgs/srv/QueryForwardKinematics`; the client's `arm.local.forward_kinematics`) and
//! `<arm>/inverse_kinematics` (`crtk_msgs/srv/QueryInverseKinematics`), with crtk_msgs'
//! definitions. Poses are in the arm's base frame, as `measured_cp`; joints in the arm's
//! order, as `measured_js`. The node answers them from its own loop with the arm's own
//! kinematics; nothing reaches the simulation.
//!
//! - **forward**: the tool frame at `jp` (every joint of the arm). A wrong length or a
//!   non-finite value answers `result = false` with the reason (and an identity pose).
//! - **inverse**: joints reaching `cp`, the solver warm-started from the reference `jp`
//!   (the arm's joints now, usually). A target inside the RCM safety distance is refused,
//!   not clamped (a query should say what it cannot reach), as is a target the solver
//!   cannot reach within its tolerances: `result = false`, the reason, and `jp` empty.

use ros2_client::{qos::History, Name, Node, QosProfile, Server, ServiceMapping, ServiceTypeName};
use serde::{Deserialize, Serialize};

use crate::robot::{Psm, RcmPolicy};
use crate::ros::msgs::Pose;
use crate::ros::names::resolve;
use crate::ros::node::NodeError;

/// `crtk_msgs/srv/QueryForwardKinematics` request.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ForwardKinematicsRequest {
    /// Joint positions, the arm's order.
    pub jp: Vec<f64>,
    /// A reference pose (crtk_msgs carries it; unused here).
    pub cp: Pose,
}

/// `crtk_msgs/srv/QueryForwardKinematics` response.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ForwardKinematicsResponse {
    /// The tool frame in the arm's base frame.
    pub cp: Pose,
    /// Whether `cp` answers the request.
    pub result: bool,
    /// Why not, when `result` is false.
    pub message: String,
}

/// `crtk_msgs/srv/QueryInverseKinematics` request.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct InverseKinematicsRequest {
    /// The tool frame asked for, in the arm's base frame.
    pub cp: Pose,
    /// The reference joints the solver starts from.
    pub jp: Vec<f64>,
}

/// `crtk_msgs/srv/QueryInverseKinematics` response.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct InverseKinematicsResponse {
    /// Joints reaching `cp`, the arm's order (empty when `result` is false).
    pub jp: Vec<f64>,
    /// Whether `jp` reaches the pose asked for.
    pub result: bool,
    /// Why not, when `result` is false.
    pub message: String,
}

impl ros2_client::Message for ForwardKinematicsRequest {}
impl ros2_client::Message for ForwardKinematicsResponse {}
impl ros2_client::Message for InverseKinematicsRequest {}
impl ros2_client::Message for InverseKinematicsResponse {}

/// The tool frame at `request.jp`.
pub fn forward(psm: &Psm, request: &ForwardKinematicsRequest) -> ForwardKinematicsResponse {
    let refuse = |message: String| ForwardKinematicsResponse {
        cp: Pose::from_isometry(&nalgebra::Isometry3::identity()),
        result: false,
        message,
    };
    if let Err(reason) = check_joints(psm, &request.jp) {
        return refuse(reason);
    }
    match psm.forward(&request.jp) {
        Ok(pose) => ForwardKinematicsResponse {
            cp: Pose::from_isometry(&pose),
            result: true,
            message: String::new(),
        },
        Err(e) => refuse(e.to_string()),
    }
}

/// Joints reaching `request.cp` from `request.jp`.
pub fn inverse(psm: &Psm, request: &InverseKinematicsRequest) -> InverseKinematicsResponse {
    let refuse = |message: String| InverseKinematicsResponse {
        jp: Vec::new(),
        result: false,
        message,
    };
    if let Err(reason) = check_joints(psm, &request.jp) {
        return refuse(format!("reference {reason}"));
    }
    let target = match request.cp.to_isometry() {
        Ok(target) => target,
        Err(e) => return refuse(format!("cp: {e}")),
    };
    match psm.solve_cartesian(&target, &request.jp, RcmPolicy::Reject) {
        Ok(solution) => InverseKinematicsResponse {
            jp: solution.ik.q,
            result: true,
            message: String::new(),
        },
        Err(e) => refuse(e.to_string()),
    }
}

/// `jp` has one finite value per joint of the arm.
fn check_joints(psm: &Psm, jp: &[f64]) -> Result<(), String> {
    let expected = psm.chain().dof();
    if jp.len() != expected {
        return Err(format!(
            "jp has {} values, the arm {expected} joints",
            jp.len()
        ));
    }
    if !jp.iter().all(|v| v.is_finite()) {
        return Err("jp has NaN or infinite values".into());
    }
    Ok(())
}

/// The two services of one arm, and its kinematics.
pub struct KinematicsServices {
    psm: Psm,
    forward: Server<ForwardKinematicsRequest, ForwardKinematicsResponse>,
    /// `local/forward_kinematics`: the same answer, since the node's poses are already in
    /// the arm's own base frame (as `local/measured_cp` is `measured_cp`).
    local_forward: Server<ForwardKinematicsRequest, ForwardKinematicsResponse>,
    inverse: Server<InverseKinematicsRequest, InverseKinematicsResponse>,
}

fn server<Req, Resp>(
    node: &mut Node,
    full_name: &str,
    type_name: &str,
) -> Result<Server<Req, Resp>, NodeError>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    let qos = QosProfile::publisher_default().history(History::KeepLast { depth: 10 });
    let err = |e: &dyn std::fmt::Debug| NodeError::Ros {
        what: format!("{full_name} service"),
        detail: format!("{e:?}"),
    };
    let (namespace, base) = full_name.rsplit_once('/').unwrap_or(("", full_name));
    let namespace = if namespace.is_empty() { "/" } else { namespace };
    let name = Name::new(namespace, base).map_err(|e| err(&e))?;
    node.create_server(
        ServiceMapping::Enhanced,
        &name,
        &ServiceTypeName::new("crtk_msgs", type_name),
        qos.clone(),
        qos,
    )
    .map_err(|e| err(&e))
}

impl KinematicsServices {
    /// The services of arm `arm` (kinematics `psm`) under `namespace`.
    pub fn start(node: &mut Node, namespace: &str, arm: &str, psm: Psm) -> Result<Self, NodeError> {
        let name = |service: &str| resolve(namespace, &format!("{arm}/{service}"));
        Ok(KinematicsServices {
            forward: server(node, &name("forward_kinematics"), "QueryForwardKinematics")?,
            local_forward: server(
                node,
                &name("local/forward_kinematics"),
                "QueryForwardKinematics",
            )?,
            inverse: server(node, &name("inverse_kinematics"), "QueryInverseKinematics")?,
            psm,
        })
    }

    /// Answers every request waiting (never blocks).
    pub fn serve(&self) {
        for server in [&self.forward, &self.local_forward] {
            while let Ok(Some((id, request))) = server.receive_request() {
                if let Err(e) = server.send_response(id, forward(&self.psm, &request)) {
                    tracing::debug!("forward_kinematics response: {e:?}");
                }
            }
        }
        while let Ok(Some((id, request))) = self.inverse.receive_request() {
            if let Err(e) = self.inverse.send_response(id, inverse(&self.psm, &request)) {
                tracing::debug!("inverse_kinematics response: {e:?}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn psm() -> Psm {
        Psm::classic("PSM1").expect("the classic PSM")
    }

    #[test]
    fn inverse_of_forward_returns_the_joints_and_bad_queries_say_why() {
        let psm = psm();
        let q = vec![0.2, -0.1, 0.12, 0.3, 0.1, -0.2];
        let fk = forward(
            &psm,
            &ForwardKinematicsRequest {
                jp: q.clone(),
                cp: Pose::default(),
            },
        );
        assert!(fk.result, "{}", fk.message);
        let ik = inverse(
            &psm,
            &InverseKinematicsRequest {
                cp: fk.cp,
                jp: vec![0.0, 0.0, 0.12, 0.0, 0.0, 0.0],
            },
        );
        assert!(ik.result, "{}", ik.message);
        let back = forward(
            &psm,
            &ForwardKinematicsRequest {
                jp: ik.jp.clone(),
                cp: Pose::default(),
            },
        );
        let reached = back.cp.to_isometry().unwrap();
        let asked = fk.cp.to_isometry().unwrap();
        assert!((reached.translation.vector - asked.translation.vector).norm() < 1e-5);
        assert!(reached.rotation.angle_to(&asked.rotation) < 1e-5);

        let short = forward(
            &psm,
            &ForwardKinematicsRequest {
                jp: vec![0.0; 3],
                cp: Pose::default(),
            },
        );
        assert!(
            !short.result && short.message.contains("3 values"),
            "{short:?}"
        );
        let nan = inverse(
            &psm,
            &InverseKinematicsRequest {
                cp: fk.cp,
                jp: vec![f64::NAN; 6],
            },
        );
        assert!(!nan.result && nan.jp.is_empty() && nan.message.contains("NaN"));
        let rcm = inverse(
            &psm,
            &InverseKinematicsRequest {
                cp: Pose::from_isometry(&nalgebra::Isometry3::identity()),
                jp: q,
            },
        );
        assert!(!rcm.result && rcm.jp.is_empty(), "{rcm:?}");
    }
}
