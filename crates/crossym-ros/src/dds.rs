//! DDS plumbing shared by the node, the mock hardware and the demo: the participant built
//! from the ROS 2 environment, ROS name expansion, QoS profiles and DDS type names.
//!
//! Environment (as `rmw` reads it):
//! - `ROS_DOMAIN_ID` (0–232, default 0);
//! - `ROS_LOCALHOST_ONLY=1` (Humble) or `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (Iron+):
//!   discovery and traffic on the loopback interface only (RustDDS `with_only_networks`);
//!   `ROS_AUTOMATIC_DISCOVERY_RANGE=OFF` is refused (no static peers here);
//! - SROS2's `ROS_SECURITY_ENABLE`, `ROS_SECURITY_STRATEGY`, `ROS_SECURITY_KEYSTORE` and
//!   `ROS_SECURITY_ENCLAVE_OVERRIDE` as rcl reads them ([`crate::sros2`]): every participant
//!   built here runs secured from its enclave's files, or not at all, or unsecured after a
//!   warning.
//!
//! Topic names follow ROS: `/abs`, `rel` (under the node namespace) and `~/priv`
//! (under `<namespace>/<node>`), mapped to DDS `rt/...` by ros2-client.

use std::net::{IpAddr, Ipv4Addr};

use ros2_client::dds::rustdds::{DomainParticipantBuilder, EventLoopHook, Topic};
use ros2_client::{Context, MessageTypeName, Name, NodeName, QosProfile, RosDistro};

use crossym_io::msg::RosMessage;

use crate::sros2::{SecurityEnv, SecurityMode, Sros2Error};

/// Errors of the DDS layer (setup only).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DdsError {
    /// A ROS environment variable has a value we cannot use.
    #[error("environment variable {var}={value:?}: {message}")]
    Env {
        /// Variable name.
        var: &'static str,
        /// Its value.
        value: String,
        /// Why it is refused.
        message: &'static str,
    },
    /// A node or topic name is not a valid ROS name.
    #[error("invalid ROS name `{name}`: {message}")]
    Name {
        /// The name as given.
        name: String,
        /// ros2-client's reason.
        message: String,
    },
    /// SROS2's variables ask for security that cannot be had (Enforce).
    #[error("DDS Security: {0}")]
    Security(#[from] Sros2Error),
    /// DDS Security refused an endpoint: the enclave's permissions do not grant it.
    #[error(
        "DDS Security: {what} not allowed by the permissions of enclave {enclave} \
         (its permissions.p7s; the policy file it was made from must grant it): {reason}"
    )]
    Forbidden {
        /// The endpoint (`publisher on /crossym/pause`, …).
        what: String,
        /// The enclave the participant runs as.
        enclave: String,
        /// RustDDS's reason.
        reason: String,
    },
    /// The DDS participant, node or an endpoint could not be created.
    #[error("DDS: {what}: {message}")]
    Create {
        /// What was being created.
        what: String,
        /// The middleware's error text.
        message: String,
    },
}

/// Where discovery may reach.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DiscoveryRange {
    /// Every interface (DDS default).
    Subnet,
    /// Loopback only.
    Localhost,
}

/// The ROS 2 distributions whose wire formats crossym speaks (`ROS_DISTRO` values).
pub const SUPPORTED_DISTROS: [RosDistro; 3] =
    [RosDistro::Humble, RosDistro::Jazzy, RosDistro::Kilted];

/// The distribution spoken when `ROS_DISTRO` is unset and no config names one: Humble, the
/// distribution of the RB-Y1 vendor's driver stack.
pub const DEFAULT_DISTRO: RosDistro = RosDistro::Humble;

/// Parses a distribution name (`ROS_DISTRO`, `[node] ros_distro`): one of
/// [`SUPPORTED_DISTROS`], else an error listing them.
pub fn parse_distro(name: &str) -> Result<RosDistro, String> {
    let n = name.trim().to_ascii_lowercase();
    SUPPORTED_DISTROS
        .into_iter()
        .find(|d| d.as_str() == n)
        .ok_or_else(|| {
            let names: Vec<&str> = SUPPORTED_DISTROS.iter().map(|d| d.as_str()).collect();
            format!(
                "unsupported ROS 2 distribution `{name}`: crossym speaks {}",
                names.join(", ")
            )
        })
}

/// The UDP ports a participant of `domain_id` may bind under RTPS's default port mapping
/// (PB 7400 + DG 250·domain, then the discovery and user ports of participants 0–119:
/// offsets 0–249).
pub fn domain_ports(domain_id: u16) -> std::ops::RangeInclusive<u32> {
    let base = 7400 + 250 * u32::from(domain_id);
    base..=base + 249
}

/// This machine's ephemeral UDP/TCP ports (Linux `net.ipv4.ip_local_port_range` of the
/// network namespace), if readable.
pub fn ephemeral_ports() -> Option<std::ops::RangeInclusive<u32>> {
    let text = std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range").ok()?;
    let mut it = text.split_whitespace().map(str::parse::<u32>);
    match (it.next(), it.next()) {
        (Some(Ok(lo)), Some(Ok(hi))) if lo <= hi => Some(lo..=hi),
        _ => None,
    }
}

/// A warning when `domain_id`'s ports overlap the `ephemeral` ports: any program's socket
/// may be handed one of them and then receives this domain's discovery, or sends another
/// domain's into it (ROS 2 advises domains 0–101 on Linux's default 32768–60999).
pub fn ephemeral_overlap(
    domain_id: u16,
    ephemeral: &std::ops::RangeInclusive<u32>,
) -> Option<String> {
    let ports = domain_ports(domain_id);
    let overlap = ports.start() <= ephemeral.end() && ephemeral.start() <= ports.end();
    overlap.then(|| {
        format!(
            "ROS_DOMAIN_ID {domain_id} uses UDP ports {}–{}, inside this machine's ephemeral \
             ports {}–{}: another program's socket may take one and carry another domain's \
             traffic into this one; choose a domain whose ports lie outside (0–101 on Linux's \
             default range) or move net.ipv4.ip_local_port_range",
            ports.start(),
            ports.end(),
            ephemeral.start(),
            ephemeral.end()
        )
    })
}

/// Domain, discovery range, ROS distribution and SROS2 security of a participant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DdsSettings {
    /// DDS domain (0–232).
    pub domain_id: u16,
    /// Discovery range.
    pub range: DiscoveryRange,
    /// The ROS 2 distribution whose graph formats are spoken.
    pub distro: RosDistro,
    /// SROS2's variables (`Default`: security off).
    pub security: SecurityEnv,
}

impl DdsSettings {
    /// Reads `ROS_DOMAIN_ID`, `ROS_LOCALHOST_ONLY`, `ROS_AUTOMATIC_DISCOVERY_RANGE`,
    /// `ROS_DISTRO` and SROS2's `ROS_SECURITY_*`.
    pub fn from_env() -> Result<Self, DdsError> {
        Self::from_vars(|k| std::env::var(k).ok())
    }

    /// As [`DdsSettings::from_env`], reading variables through `get` (testable).
    pub fn from_vars(get: impl Fn(&str) -> Option<String>) -> Result<Self, DdsError> {
        let domain_id = match get("ROS_DOMAIN_ID").filter(|v| !v.trim().is_empty()) {
            None => 0,
            Some(v) => match v.trim().parse::<u16>() {
                Ok(d) if d <= 232 => d,
                _ => {
                    return Err(DdsError::Env {
                        var: "ROS_DOMAIN_ID",
                        value: v,
                        message: "must be an integer in 0..=232",
                    })
                }
            },
        };
        let mut range = DiscoveryRange::Subnet;
        if let Some(v) = get("ROS_LOCALHOST_ONLY") {
            match v.trim() {
                "1" => range = DiscoveryRange::Localhost,
                "" | "0" => {}
                _ => {
                    return Err(DdsError::Env {
                        var: "ROS_LOCALHOST_ONLY",
                        value: v,
                        message: "must be 0 or 1",
                    })
                }
            }
        }
        if let Some(v) = get("ROS_AUTOMATIC_DISCOVERY_RANGE") {
            match v.trim() {
                "LOCALHOST" => range = DiscoveryRange::Localhost,
                "" | "SUBNET" | "SYSTEM_DEFAULT" => {}
                "OFF" => {
                    return Err(DdsError::Env {
                        var: "ROS_AUTOMATIC_DISCOVERY_RANGE",
                        value: v,
                        message: "OFF (no automatic discovery) is not supported",
                    })
                }
                _ => {
                    return Err(DdsError::Env {
                        var: "ROS_AUTOMATIC_DISCOVERY_RANGE",
                        value: v,
                        message: "must be SUBNET, LOCALHOST, OFF or SYSTEM_DEFAULT",
                    })
                }
            }
        }
        let distro = match get("ROS_DISTRO").filter(|v| !v.trim().is_empty()) {
            None => DEFAULT_DISTRO,
            Some(v) => parse_distro(&v).map_err(|_| DdsError::Env {
                var: "ROS_DISTRO",
                value: v,
                message: "crossym speaks humble, jazzy and kilted",
            })?,
        };
        let security = SecurityEnv::from_vars(&get);
        Ok(Self {
            domain_id,
            range,
            distro,
            security,
        })
    }

    /// These settings with `--ros-args --enclave` (rcl: `ROS_SECURITY_ENCLAVE_OVERRIDE`,
    /// when set, still wins).
    pub fn with_enclave(mut self, enclave: Option<&str>) -> Self {
        self.security = self.security.with_ros_enclave(enclave);
        self
    }

    /// What a participant built from these settings will be: secured as which enclave,
    /// off, or unsecured after a warning (permissive); an error where Enforce stops.
    pub fn security_mode(&self) -> Result<SecurityMode, DdsError> {
        Ok(self.security.resolve()?)
    }

    /// These settings with `distro` (e.g. a config's `[node] ros_distro`).
    pub fn with_distro(self, distro: RosDistro) -> Self {
        Self { distro, ..self }
    }

    /// These settings with a config's `[node] ros_distro`, which wins over `ROS_DISTRO`
    /// when given; a name crossym does not speak is refused.
    pub fn with_config_distro(self, name: Option<&str>) -> Result<Self, DdsError> {
        match name {
            None => Ok(self),
            Some(d) => parse_distro(d)
                .map(|distro| self.with_distro(distro))
                .map_err(|_| DdsError::Env {
                    var: "[node] ros_distro",
                    value: d.to_string(),
                    message: "crossym speaks humble, jazzy and kilted",
                }),
        }
    }

    /// Creates the ros2-client context (one DDS participant).
    pub fn context(&self) -> Result<Context, DdsError> {
        self.context_with_hook(None)
    }

    /// Creates the ros2-client context with `hook` run on its participant's event-loop
    /// thread (RustDDS's event-loop hook, vendor/README.md): the hook reads and writes on
    /// the thread that receives and transmits, with no hand-off between threads.
    pub fn context_with_hook(
        &self,
        hook: Option<Box<dyn EventLoopHook>>,
    ) -> Result<Context, DdsError> {
        // Process-wide in ros2-client: every participant of a process speaks one
        // distribution (the last context created sets it; crossym's processes use one).
        ros2_client::set_ros_distro(self.distro);
        let mut b = DomainParticipantBuilder::new(self.domain_id);
        if let Some(h) = hook {
            b = b.event_loop_hook(h);
        }
        if self.range == DiscoveryRange::Localhost {
            b = b.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        }
        let mode = self.security_mode()?;
        #[cfg(feature = "security")]
        if let SecurityMode::Secured { dir, .. } = &mode {
            use ros2_client::dds::rustdds::DomainParticipantSecurityConfigFiles as Files;
            b = b.builtin_security(Files::with_ros_default_names(dir, String::new()));
        }
        let dp = b.build().map_err(|e| DdsError::Create {
            what: match &mode {
                SecurityMode::Secured { enclave, dir, .. } => format!(
                    "secured participant in domain {} (enclave {enclave}, {})",
                    self.domain_id,
                    dir.display()
                ),
                _ => format!("participant in domain {}", self.domain_id),
            },
            message: e.to_string(),
        })?;
        *SECURED_ENCLAVE.lock().unwrap_or_else(|p| p.into_inner()) =
            mode.enclave().map(String::from);
        Context::from_domain_participant(dp).map_err(|e| DdsError::Create {
            what: "ROS 2 context".into(),
            message: e.to_string(),
        })
    }
}

/// The enclave of the last secured participant this process built (error messages only).
static SECURED_ENCLAVE: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// The [`DdsError`] of a failed creation of `what` (an endpoint, a service): a refusal by
/// DDS Security becomes [`DdsError::Forbidden`] naming the enclave, anything else
/// [`DdsError::Create`].
pub fn create_error(what: impl Into<String>, e: &ros2_client::CreateError) -> DdsError {
    let message = format!("{e}");
    let enclave = SECURED_ENCLAVE
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone();
    match (message.find("not allowed by security"), enclave) {
        (Some(at), Some(enclave)) => DdsError::Forbidden {
            what: what.into(),
            enclave,
            reason: message[at..].to_string(),
        },
        _ => DdsError::Create {
            what: what.into(),
            message: format!("{e:?}"),
        },
    }
}

/// The node name `namespace`/`name`.
pub fn node_name(namespace: &str, name: &str) -> Result<NodeName, DdsError> {
    NodeName::new(namespace, name).map_err(|e| DdsError::Name {
        name: format!("{namespace}/{name}"),
        message: format!("{e:?}"),
    })
}

/// Expands a ROS topic name (`/abs`, `rel`, `~/priv`) to its absolute form.
pub fn expand_topic(topic: &str, namespace: &str, node: &str) -> String {
    let ns = namespace.trim_end_matches('/');
    if let Some(rest) = topic.strip_prefix("~/") {
        format!("{ns}/{node}/{rest}")
    } else if topic.starts_with('/') {
        topic.to_string()
    } else {
        format!("{ns}/{topic}")
    }
}

/// The ros2-client [`Name`] of `topic` for a node `name` in `namespace`.
pub fn topic_name(topic: &str, namespace: &str, node: &str) -> Result<Name, DdsError> {
    let full = expand_topic(topic, namespace, node);
    Name::parse(&full).map_err(|e| DdsError::Name {
        name: full.clone(),
        message: format!("{e:?}"),
    })
}

/// The ros2-client type name of message `M` (`pkg/msg/Type` → `pkg::msg::dds_::Type_`).
pub fn type_name<M: RosMessage>() -> MessageTypeName {
    let pkg = M::ROS_TYPE.split('/').next().unwrap_or_default();
    let ty = M::ROS_TYPE.rsplit('/').next().unwrap_or_default();
    MessageTypeName::new(pkg, ty)
}

/// QoS of a sensor stream subscription (best effort matches reliable and best-effort writers).
pub fn qos_sensor() -> QosProfile {
    QosProfile::subscription_default().history(ros2_client::qos::History::KeepLast { depth: 5 })
}

/// Reliable, volatile, keep-last `depth` (commands, status, conditions).
pub fn qos_reliable(depth: usize) -> QosProfile {
    QosProfile::publisher_default().history(ros2_client::qos::History::KeepLast { depth })
}

/// [`qos_reliable`] for a writer on the DDS event-loop thread (an event-loop hook): a
/// publish on a full send window (a reader that stopped acknowledging) fails at once
/// instead of waiting for acknowledgements that the blocked loop itself would process.
pub fn qos_reliable_nonblocking(depth: usize) -> QosProfile {
    qos_reliable(depth).reliability_reliable(ros2_client::qos::WhenFull::Fail)
}

/// Creates a topic of message type `M` on `node`.
pub fn create_topic<M: RosMessage>(
    node: &ros2_client::Node,
    name: &Name,
    qos: &QosProfile,
) -> Result<Topic, DdsError> {
    node.create_topic(name, type_name::<M>(), qos)
        .map_err(|e| create_error(format!("topic {name}"), &e))
}

/// Creates a publisher of `M` on `topic` (ROS name) for `node`.
pub fn publisher<M: RosMessage + serde::Serialize>(
    node: &mut ros2_client::Node,
    topic: &str,
    qos: QosProfile,
) -> Result<ros2_client::Publisher<M>, DdsError> {
    let name = topic_name(topic, node.namespace(), &node_base_name(node))?;
    let t = create_topic::<M>(node, &name, &qos)?;
    node.create_publisher(&t, Some(qos))
        .map_err(|e| create_error(format!("publisher on {name}"), &e))
}

/// Creates a subscription of `M` on `topic` (ROS name) for `node`.
pub fn subscription<M: RosMessage + serde::de::DeserializeOwned + 'static>(
    node: &mut ros2_client::Node,
    topic: &str,
    qos: QosProfile,
) -> Result<ros2_client::Subscription<M>, DdsError> {
    let name = topic_name(topic, node.namespace(), &node_base_name(node))?;
    let t = create_topic::<M>(node, &name, &qos)?;
    node.create_subscription(&t, Some(qos))
        .map_err(|e| create_error(format!("subscription on {name}"), &e))
}

fn node_base_name(node: &ros2_client::Node) -> String {
    let full = node.fully_qualified_name();
    full.rsplit('/').next().unwrap_or_default().to_string()
}

/// The current ROS (wall-clock) time (ns since the Unix epoch).
pub fn wall_time_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

/// The current ROS (wall-clock) time (s since the Unix epoch).
pub fn wall_time_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// Resolves on the first SIGINT or SIGTERM (inside a tokio runtime with signals enabled).
pub async fn shutdown_signal() -> std::io::Result<()> {
    use tokio::signal::unix::{signal, SignalKind};
    let mut int = signal(SignalKind::interrupt())?;
    let mut term = signal(SignalKind::terminate())?;
    tokio::select! {
        _ = int.recv() => {}
        _ = term.recv() => {}
    }
    Ok(())
}

#[cfg(test)]
mod port_tests {
    use super::*;

    #[test]
    fn a_domain_in_the_ephemeral_range_is_warned_about_and_one_below_is_not() {
        let linux = 32768..=60999;
        assert_eq!(domain_ports(0), 7400..=7649);
        // Domain 100 ends at 32649; 101 reaches 32899, past 32768.
        assert_eq!(ephemeral_overlap(100, &linux), None);
        let w = ephemeral_overlap(101, &linux).expect("101 overlaps");
        assert!(
            w.contains("32650–32899") && w.contains("32768–60999"),
            "{w}"
        );
        assert!(ephemeral_overlap(197, &linux).is_some());
        // Domain 214 starts at 60900 (inside), 215 at 61150 (above).
        assert!(ephemeral_overlap(214, &linux).is_some());
        assert_eq!(ephemeral_overlap(215, &linux), None);
        // tools/netns-run's range keeps domains 0-209 clear.
        let netns = 60000..=65535;
        assert_eq!(ephemeral_overlap(209, &netns), None);
        assert!(ephemeral_overlap(210, &netns).is_some());
    }
}

#[cfg(test)]
mod distro_tests {
    use super::*;
    use ros2_client::entities_info::ParticipantEntitiesInfo;
    use ros2_client::Gid;

    /// `rmw_dds_common/msg/ParticipantEntitiesInfo` with no node, as rmw writes it:
    /// `Gid gid` (`char[24] data` up to Humble, `char[16]` from Iron on), then an empty
    /// `NodeEntitiesInfo[]` (a 4-byte length 0). Built by hand from the .msg definitions.
    fn by_hand(gid_len: usize) -> Vec<u8> {
        let mut b: Vec<u8> = (1..=16).collect();
        b.resize(gid_len, 0);
        b.extend_from_slice(&0u32.to_le_bytes());
        b
    }

    #[test]
    fn the_discovery_info_speaks_the_selected_distribution() {
        let gid = Gid::from(std::array::from_fn::<u8, 16, _>(|i| i as u8 + 1));
        let info = ParticipantEntitiesInfo::new(gid, vec![]);
        for (name, len) in [("humble", 24), ("jazzy", 16), ("kilted", 16)] {
            ros2_client::set_ros_distro(parse_distro(name).unwrap());
            let bytes = cdr_encoding::to_vec::<_, byteorder::LittleEndian>(&info).unwrap();
            assert_eq!(bytes, by_hand(len), "{name}");
            let (back, _) = cdr_encoding::from_bytes::<
                ParticipantEntitiesInfo,
                byteorder::LittleEndian,
            >(&by_hand(len))
            .unwrap();
            assert_eq!(back.gid(), gid, "{name}");
        }
        ros2_client::set_ros_distro(DEFAULT_DISTRO);
    }

    #[test]
    fn ros_distro_is_read_and_checked() {
        let vars = |d: Option<&'static str>| {
            move |k: &str| (k == "ROS_DISTRO").then(|| d.map(String::from)).flatten()
        };
        let s = DdsSettings::from_vars(vars(None)).unwrap();
        assert_eq!(s.distro, RosDistro::Humble);
        let s = DdsSettings::from_vars(vars(Some("kilted"))).unwrap();
        assert_eq!(s.distro, RosDistro::Kilted);
        let e = DdsSettings::from_vars(vars(Some("foxy")))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("ROS_DISTRO") && e.contains("humble, jazzy and kilted"),
            "{e}"
        );
        assert!(parse_distro("rolling")
            .unwrap_err()
            .contains("humble, jazzy, kilted"));
    }
}
