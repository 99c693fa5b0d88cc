//! The node as a managed (lifecycle) node: the state machine of ROS 2's managed nodes
//! (`rcl_lifecycle`'s default one) and its services, as `ros2 lifecycle`, launch's
//! lifecycle events and ros2_control's controller manager drive them.
//!
//! States: `unconfigured` (1) → `configure` → `inactive` (2) → `activate` → `active` (3);
//! `deactivate` back to inactive, `cleanup` from inactive to unconfigured, `shutdown` from
//! any of the three to `finalized` (4). Each transition passes through its transition state
//! (`configuring` 10, `cleaningup` 11, `shuttingdown` 12, `activating` 13, `deactivating`
//! 14) and is published on `~/transition_event` as two events, as rcl does: the transition
//! into the transition state, then `transition_success` into the goal.
//!
//! What the states mean for the robot: only `active` runs the policy and publishes
//! commands. Leaving `active` (deactivate, shutdown) brakes like `~/pause` — to zero at the
//! acceleration limits — and publishes the braking commands until the first zero one, then
//! nothing: the robot's own controller holds. The subscriptions stay up in every state
//! (the status reports `INACTIVE` with the joint states' age). `[node] autostart = true`
//! (the default) starts the node active; `false` (the RB-Y1 configs) starts it inactive:
//! nothing moves until someone says `activate`.
//!
//! Services (`lifecycle_msgs`, reliable, keep last 10, rmw_fastrtps's request/reply
//! mapping): `~/change_state`, `~/get_state`, `~/get_available_states`,
//! `~/get_available_transitions`, `~/get_transition_graph`. A `ChangeState` request with a
//! label is looked up by its label (rclcpp's rule: `ros2 service call` leaves the id 0).

use crossym_io::msg::{LifecycleState, LifecycleTransition, TransitionDescription};
use ros2_client::service::{Server, ServiceMapping};
use ros2_client::{Name, ServiceTypeName};
use serde::{Deserialize, Serialize};

use crate::dds;
use crate::dds::DdsError;

/// A primary state of a managed node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Primary {
    /// Created, not configured.
    Unconfigured,
    /// Configured: subscribed, publishing no command.
    Inactive,
    /// Running the policy and commanding the robot.
    Active,
    /// Shut down: no transition leaves it.
    Finalized,
}

impl Primary {
    /// The `lifecycle_msgs/State` id.
    pub fn id(self) -> u8 {
        match self {
            Primary::Unconfigured => 1,
            Primary::Inactive => 2,
            Primary::Active => 3,
            Primary::Finalized => 4,
        }
    }

    /// The `lifecycle_msgs/State` label.
    pub fn label(self) -> &'static str {
        state_label(self.id())
    }

    /// As a `lifecycle_msgs/State`.
    pub fn state(self) -> LifecycleState {
        state(self.id())
    }
}

/// The label rcl gives state `id` (primary and transition states).
fn state_label(id: u8) -> &'static str {
    match id {
        1 => "unconfigured",
        2 => "inactive",
        3 => "active",
        4 => "finalized",
        10 => "configuring",
        11 => "cleaningup",
        12 => "shuttingdown",
        13 => "activating",
        14 => "deactivating",
        15 => "errorprocessing",
        _ => "unknown",
    }
}

fn state(id: u8) -> LifecycleState {
    LifecycleState {
        id,
        label: state_label(id).into(),
    }
}

/// One transition of the default state machine out of a primary state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Edge {
    /// `lifecycle_msgs/Transition` id.
    id: u8,
    label: &'static str,
    from: Primary,
    /// The transition state passed through.
    via: u8,
    to: Primary,
    /// The id of the `transition_success` step (`on_<transition>_success`).
    success: u8,
}

/// rcl's default state machine, the transitions a client can trigger.
const EDGES: [Edge; 7] = [
    edge(
        1,
        "configure",
        Primary::Unconfigured,
        10,
        Primary::Inactive,
        10,
    ),
    edge(
        2,
        "cleanup",
        Primary::Inactive,
        11,
        Primary::Unconfigured,
        20,
    ),
    edge(3, "activate", Primary::Inactive, 13, Primary::Active, 30),
    edge(4, "deactivate", Primary::Active, 14, Primary::Inactive, 40),
    edge(
        5,
        "shutdown",
        Primary::Unconfigured,
        12,
        Primary::Finalized,
        50,
    ),
    edge(6, "shutdown", Primary::Inactive, 12, Primary::Finalized, 50),
    edge(7, "shutdown", Primary::Active, 12, Primary::Finalized, 50),
];

const fn edge(
    id: u8,
    label: &'static str,
    from: Primary,
    via: u8,
    to: Primary,
    success: u8,
) -> Edge {
    Edge {
        id,
        label,
        from,
        via,
        to,
        success,
    }
}

/// A transition taken: what the node does and what `~/transition_event` says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Change {
    /// The state left.
    pub from: Primary,
    /// The state reached.
    pub to: Primary,
    /// The two `TransitionEvent`s rcl publishes: into the transition state, then out of it.
    pub events: [TransitionDescription; 2],
}

impl Change {
    /// The policy starts (`Some(true)`) or stops (`Some(false)`), or neither.
    pub fn activation(&self) -> Option<bool> {
        match (self.from, self.to) {
            (f, Primary::Active) if f != Primary::Active => Some(true),
            (Primary::Active, t) if t != Primary::Active => Some(false),
            _ => None,
        }
    }
}

/// Why a transition is refused (the state stays).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LifecycleRefusal {
    /// No transition of that id or label leaves the current state.
    #[error("no transition {asked} from state `{state}` (available: {available})")]
    Unavailable {
        /// The transition as asked (`id 3` or `label "activate"`).
        asked: String,
        /// The current state's label.
        state: &'static str,
        /// The labels that are available.
        available: String,
    },
}

/// The node's lifecycle state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lifecycle {
    state: Primary,
}

impl Lifecycle {
    /// Starts in `state`.
    pub fn new(state: Primary) -> Self {
        Self { state }
    }

    /// The current primary state.
    pub fn state(&self) -> Primary {
        self.state
    }

    fn available(&self) -> impl Iterator<Item = &'static Edge> + '_ {
        EDGES.iter().filter(move |e| e.from == self.state)
    }

    /// The transitions available now (`GetAvailableTransitions`: into the transition state).
    pub fn available_transitions(&self) -> Vec<TransitionDescription> {
        self.available().map(first_step).collect()
    }

    /// Takes the transition `id`, or the one labelled `label` when the label is not empty.
    pub fn change(&mut self, id: u8, label: &str) -> Result<Change, LifecycleRefusal> {
        let found = if label.is_empty() {
            self.available().find(|e| e.id == id)
        } else {
            self.available().find(|e| e.label == label)
        };
        let Some(e) = found else {
            return Err(LifecycleRefusal::Unavailable {
                asked: if label.is_empty() {
                    format!("id {id}")
                } else {
                    format!("label {label:?}")
                },
                state: self.state.label(),
                available: self
                    .available()
                    .map(|e| format!("{} ({})", e.label, e.id))
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        };
        let change = Change {
            from: e.from,
            to: e.to,
            events: [
                first_step(e),
                TransitionDescription {
                    transition: LifecycleTransition {
                        id: e.success,
                        label: "transition_success".into(),
                    },
                    start_state: state(e.via),
                    goal_state: e.to.state(),
                },
            ],
        };
        self.state = e.to;
        Ok(change)
    }
}

fn first_step(e: &Edge) -> TransitionDescription {
    TransitionDescription {
        transition: LifecycleTransition {
            id: e.id,
            label: e.label.into(),
        },
        start_state: e.from.state(),
        goal_state: state(e.via),
    }
}

/// The `source` an activation or deactivation is handed to the control thread with
/// (`NodeCore::apply`), naming the transition: `"lifecycle activate"`, `"lifecycle
/// deactivate"`, `"lifecycle shutdown"`.
pub fn source_of(change: &Change) -> &'static str {
    match (change.activation(), change.to) {
        (Some(true), _) => "lifecycle activate",
        (_, Primary::Finalized) => "lifecycle shutdown",
        _ => "lifecycle deactivate",
    }
}

/// The `TransitionEvent` that ends the transition applied as `active` from `source`
/// ([`source_of`]) at `timestamp` (ns): what a bag records and replay applies.
pub fn applied_event(
    active: bool,
    source: &str,
    timestamp: u64,
) -> crossym_io::msg::TransitionEvent {
    let (id, via, to) = if active {
        (30, 13, Primary::Active)
    } else if source.ends_with("shutdown") {
        (50, 12, Primary::Finalized)
    } else {
        (40, 14, Primary::Inactive)
    };
    crossym_io::msg::TransitionEvent {
        timestamp,
        transition: LifecycleTransition {
            id,
            label: "transition_success".into(),
        },
        start_state: state(via),
        goal_state: to.state(),
    }
}

/// Starts the node's core in its lifecycle state: a core is active when built (the
/// DDS-free simulations and benches run it so); `[node] autostart = false` makes it
/// inactive before its first tick. Used by the node and by bag replay alike.
pub fn apply_autostart(core: &mut crossym_control::node::NodeCore) {
    if !core.config().autostart {
        // Activate(false) is never refused (no value to check).
        let _ = core.apply(crossym_control::node::OperatorRequest::Activate(false));
    }
}

/// Every state of the machine (`GetAvailableStates`), primary then transition states.
pub fn all_states() -> Vec<LifecycleState> {
    [1, 2, 3, 4, 10, 11, 12, 13, 14, 15]
        .into_iter()
        .map(state)
        .collect()
}

/// Every transition of the machine (`~/get_transition_graph`), each step of each.
pub fn transition_graph() -> Vec<TransitionDescription> {
    let mut all = Vec::new();
    for e in &EDGES {
        let mut m = Lifecycle::new(e.from);
        if let Ok(c) = m.change(e.id, "") {
            all.extend(c.events);
        }
    }
    all
}

/// `lifecycle_msgs/srv/ChangeState` request.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ChangeStateRequest {
    /// The transition asked for (by label when the label is not empty).
    pub transition: LifecycleTransition,
}

/// `lifecycle_msgs/srv/ChangeState` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ChangeStateResponse {
    /// The transition was taken.
    pub success: bool,
}

/// An empty request (`GetState`, `GetAvailableStates`, `GetAvailableTransitions`; IDL
/// needs one member).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EmptyRequest {
    /// Unused.
    pub structure_needs_at_least_one_member: u8,
}

/// `lifecycle_msgs/srv/GetState` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetStateResponse {
    /// The current primary state.
    pub current_state: LifecycleState,
}

/// `lifecycle_msgs/srv/GetAvailableStates` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetAvailableStatesResponse {
    /// Every state of the machine.
    pub available_states: Vec<LifecycleState>,
}

/// `lifecycle_msgs/srv/GetAvailableTransitions` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetAvailableTransitionsResponse {
    /// The transitions (available now, or the whole graph).
    pub available_transitions: Vec<TransitionDescription>,
}

impl ros2_client::Message for ChangeStateRequest {}
impl ros2_client::Message for ChangeStateResponse {}
impl ros2_client::Message for EmptyRequest {}
impl ros2_client::Message for GetStateResponse {}
impl ros2_client::Message for GetAvailableStatesResponse {}
impl ros2_client::Message for GetAvailableTransitionsResponse {}

/// The lifecycle services' names and types, for the startup log.
pub(super) const NAMES: [(&str, &str); 5] = [
    ("change_state", "lifecycle_msgs/srv/ChangeState"),
    ("get_state", "lifecycle_msgs/srv/GetState"),
    (
        "get_available_states",
        "lifecycle_msgs/srv/GetAvailableStates",
    ),
    (
        "get_available_transitions",
        "lifecycle_msgs/srv/GetAvailableTransitions",
    ),
    (
        "get_transition_graph",
        "lifecycle_msgs/srv/GetAvailableTransitions",
    ),
];

/// The lifecycle services and the transition event publisher.
pub(super) struct LifecycleServices {
    pub(super) change_state: Server<ChangeStateRequest, ChangeStateResponse>,
    pub(super) get_state: Server<EmptyRequest, GetStateResponse>,
    pub(super) get_available_states: Server<EmptyRequest, GetAvailableStatesResponse>,
    pub(super) get_available_transitions: Server<EmptyRequest, GetAvailableTransitionsResponse>,
    pub(super) get_transition_graph: Server<EmptyRequest, GetAvailableTransitionsResponse>,
    pub(super) events: ros2_client::Publisher<crossym_io::msg::TransitionEvent>,
}

impl LifecycleServices {
    /// Creates the five services (reliable, keep last 10) and `~/transition_event`
    /// (reliable, keep last 10, as rclcpp's).
    pub(super) fn create(node: &mut ros2_client::Node) -> Result<Self, DdsError> {
        Ok(Self {
            change_state: server(node, NAMES[0])?,
            get_state: server(node, NAMES[1])?,
            get_available_states: server(node, NAMES[2])?,
            get_available_transitions: server(node, NAMES[3])?,
            get_transition_graph: server(node, NAMES[4])?,
            events: dds::publisher(node, "~/transition_event", dds::qos_reliable(10))?,
        })
    }
}

fn server<Q, P>(
    node: &mut ros2_client::Node,
    (name, ty): (&str, &str),
) -> Result<Server<Q, P>, DdsError>
where
    Q: ros2_client::Message + Clone + 'static,
    P: ros2_client::Message + 'static,
{
    let full = node.fully_qualified_name();
    let qos = dds::qos_reliable(10);
    let err = |e: String| DdsError::Create {
        what: format!("service ~/{name}"),
        message: e,
    };
    let n = Name::new(&full, name).map_err(|e| err(format!("{e:?}")))?;
    let pkg = ty.split('/').next().unwrap_or_default();
    let t = ty.rsplit('/').next().unwrap_or_default();
    node.create_server(
        ServiceMapping::Enhanced,
        &n,
        &ServiceTypeName::new(pkg, t),
        qos.clone(),
        qos,
    )
    .map_err(|e| err(format!("{e:?}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_state_machine() {
        let mut l = Lifecycle::new(Primary::Inactive);
        let ids: Vec<u8> = l
            .available_transitions()
            .iter()
            .map(|t| t.transition.id)
            .collect();
        assert_eq!(ids, [2, 3, 6]);
        let c = l.change(3, "").unwrap();
        assert_eq!(
            (c.from, c.to, c.activation()),
            (Primary::Inactive, Primary::Active, Some(true))
        );
        assert_eq!(c.events[0].goal_state, state(13));
        assert_eq!(c.events[0].goal_state.label, "activating");
        assert_eq!(
            (c.events[1].transition.id, c.events[1].goal_state.id),
            (30, 3)
        );
        // Activate again: not available from active.
        assert!(matches!(
            l.change(3, ""),
            Err(LifecycleRefusal::Unavailable { .. })
        ));
        let c = l.change(0, "deactivate").unwrap();
        assert_eq!((c.to, c.activation()), (Primary::Inactive, Some(false)));
        let c = l.change(2, "").unwrap();
        assert_eq!((c.to, c.activation()), (Primary::Unconfigured, None));
        let c = l.change(1, "configure").unwrap();
        assert_eq!(c.to, Primary::Inactive);
        l.change(3, "").unwrap();
        // Shutdown from active: labelled "shutdown", id 7; stops the policy.
        let c = l.change(0, "shutdown").unwrap();
        assert_eq!(
            (c.events[0].transition.id, c.to, c.activation()),
            (7, Primary::Finalized, Some(false))
        );
        assert!(l.available_transitions().is_empty());
        let e = l.change(1, "").unwrap_err().to_string();
        assert!(e.contains("finalized"), "{e}");
    }

    #[test]
    fn a_label_wins_over_the_id_and_an_unknown_label_is_refused() {
        let mut l = Lifecycle::new(Primary::Inactive);
        // rclcpp: `ros2 service call … "{transition: {label: activate}}"` sends id 0.
        assert_eq!(l.change(0, "activate").unwrap().to, Primary::Active);
        let mut l = Lifecycle::new(Primary::Inactive);
        let e = l.change(3, "fly").unwrap_err().to_string();
        assert!(e.contains("\"fly\"") && e.contains("activate (3)"), "{e}");
        assert_eq!(l.state(), Primary::Inactive);
    }

    #[test]
    fn states_and_graph_as_rcl_lists_them() {
        let s = all_states();
        assert_eq!(s.len(), 10);
        assert_eq!(s[2].label, "active");
        let g = transition_graph();
        assert_eq!(g.len(), 14);
        assert!(g
            .iter()
            .any(|t| t.transition.label == "transition_success" && t.goal_state.id == 4));
    }
}
