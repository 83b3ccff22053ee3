//! The node's parameters, read-only, on the standard parameter services
//! (`<node>/list_parameters`, `get_parameters`, `get_parameter_types`,
//! `describe_parameters`, `set_parameters`), so `ros2 param list` and `ros2 param get` show
//! the values the node runs with. ros2-client serves these from its spinner, which the node
//! does not run ([`crate::ros::sim_clock`]); they are answered from the node's own loop here.
//! Setting a parameter is refused with the reason: the values are fixed at start
//! (`--ros-args -p`, [`crate::ros::ros_args`]).

use ros2_client::parameters::raw::{
    ParameterDescriptor, ParameterType, ParameterValue, SetParametersResult,
};
use ros2_client::rcl_interfaces::{
    DescribeParametersRequest, DescribeParametersResponse, GetParameterTypesRequest,
    GetParameterTypesResponse, GetParametersRequest, GetParametersResponse, ListParametersRequest,
    ListParametersResponse, ListParametersResult, SetParametersRequest, SetParametersResponse,
};
use ros2_client::{
    qos::History, Message, Name, Node, QosProfile, Server, ServiceMapping, ServiceTypeName,
};

use crate::ros::node::NodeError;
use crate::ros::ros_args::{ParamValue, PARAMETERS};

/// The parameter services of one node.
pub struct ParameterServices {
    list: Server<ListParametersRequest, ListParametersResponse>,
    get: Server<GetParametersRequest, GetParametersResponse>,
    types: Server<GetParameterTypesRequest, GetParameterTypesResponse>,
    describe: Server<DescribeParametersRequest, DescribeParametersResponse>,
    set: Server<SetParametersRequest, SetParametersResponse>,
    /// Name and value of each declared parameter ([`PARAMETERS`]).
    declared: Vec<(String, ParamValue)>,
}

fn server<Req: Message + Clone + 'static, Resp: Message + 'static>(
    node: &mut Node,
    service: &str,
    type_name: &str,
) -> Result<Server<Req, Resp>, NodeError> {
    let qos = QosProfile::publisher_default().history(History::KeepLast { depth: 10 });
    let fqn = node.fully_qualified_name();
    let err = |e: &dyn std::fmt::Debug| NodeError::Ros {
        what: format!("{fqn}/{service} service"),
        detail: format!("{e:?}"),
    };
    let name = Name::new(&fqn, service).map_err(|e| err(&e))?;
    node.create_server(
        ServiceMapping::Enhanced,
        &name,
        &ServiceTypeName::new("rcl_interfaces", type_name),
        qos.clone(),
        qos,
    )
    .map_err(|e| err(&e))
}

fn type_of(value: &ParamValue) -> u8 {
    match value {
        ParamValue::Bool(_) => ParameterType::BOOL,
        ParamValue::Double(_) => ParameterType::DOUBLE,
        ParamValue::Text(_) => ParameterType::STRING,
    }
}

fn raw(value: Option<&ParamValue>) -> ParameterValue {
    let mut v = ParameterValue {
        ptype: value.map(type_of).unwrap_or(ParameterType::NOT_SET),
        boolean_value: false,
        int_value: 0,
        double_value: 0.0,
        string_value: String::new(),
        byte_array: vec![],
        bool_array: vec![],
        int_array: vec![],
        double_array: vec![],
        string_array: vec![],
    };
    match value {
        Some(ParamValue::Bool(b)) => v.boolean_value = *b,
        Some(ParamValue::Double(d)) => v.double_value = *d,
        Some(ParamValue::Text(t)) => v.string_value = t.clone(),
        None => {}
    }
    v
}

impl ParameterServices {
    /// The services on `node`, serving `declared`.
    pub fn start(node: &mut Node, declared: Vec<(String, ParamValue)>) -> Result<Self, NodeError> {
        Ok(ParameterServices {
            list: server(node, "list_parameters", "ListParameters")?,
            get: server(node, "get_parameters", "GetParameters")?,
            types: server(node, "get_parameter_types", "GetParameterTypes")?,
            describe: server(node, "describe_parameters", "DescribeParameters")?,
            set: server(node, "set_parameters", "SetParameters")?,
            declared,
        })
    }

    fn find(&self, name: &str) -> Option<&ParamValue> {
        self.declared
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v)
    }

    /// Answers every request waiting (never blocks).
    pub fn serve(&self) {
        fn answer<Req, Resp>(server: &Server<Req, Resp>, respond: impl Fn(Req) -> Resp)
        where
            Req: Message + Clone + 'static,
            Resp: Message + 'static,
        {
            while let Ok(Some((id, request))) = server.receive_request() {
                if let Err(e) = server.send_response(id, respond(request)) {
                    tracing::debug!("parameter service response: {e:?}");
                }
            }
        }
        answer(&self.list, |r: ListParametersRequest| {
            let names = self
                .declared
                .iter()
                .map(|(n, _)| n.clone())
                .filter(|n| {
                    r.prefixes.is_empty()
                        || r.prefixes
                            .iter()
                            .any(|p| n == p || n.starts_with(&format!("{p}.")))
                })
                .collect();
            ListParametersResponse {
                result: ListParametersResult {
                    names,
                    prefixes: vec![],
                },
            }
        });
        answer(&self.get, |r: GetParametersRequest| GetParametersResponse {
            values: r.names.iter().map(|n| raw(self.find(n))).collect(),
        });
        answer(&self.types, |r: GetParameterTypesRequest| {
            GetParameterTypesResponse {
                values: r
                    .names
                    .iter()
                    .map(|n| self.find(n).map(type_of).unwrap_or(ParameterType::NOT_SET))
                    .collect(),
            }
        });
        answer(&self.describe, |r: DescribeParametersRequest| {
            DescribeParametersResponse {
                values: r
                    .names
                    .iter()
                    .map(|n| ParameterDescriptor {
                        name: n.clone(),
                        r#type: self.find(n).map(type_of).unwrap_or(ParameterType::NOT_SET),
                        description: PARAMETERS
                            .iter()
                            .find(|(p, _)| p == n)
                            .map(|(_, d)| (*d).to_owned())
                            .unwrap_or_default(),
                        additional_constraints: String::new(),
                        read_only: true,
                        dynamic_typing: false,
                        floating_point_range: vec![],
                        integer_range: vec![],
                    })
                    .collect(),
            }
        });
        answer(&self.set, |r: SetParametersRequest| SetParametersResponse {
            results: r
                .parameter
                .iter()
                .map(|p| SetParametersResult {
                    successful: false,
                    reason: format!(
                        "{}: read-only; set it at start with --ros-args -p {}:=VALUE",
                        p.name, p.name
                    ),
                })
                .collect(),
        });
    }
}
