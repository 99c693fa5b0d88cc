//! sros2 policy files and the DDS Security documents made from them.
//!
//! A policy (sros2's schema, version `0.2.0`) names per enclave what its nodes may do with
//! ROS names:
//!
//! ```xml
//! <policy version="0.2.0">
//!   <enclaves>
//!     <enclave path="/crossym/node">
//!       <profiles>
//!         <profile ns="/" node="crossym">
//!           <topics subscribe="ALLOW"><topic>/joint_states</topic></topics>
//!           <topics publish="ALLOW"><topic>~/status</topic></topics>
//!           <services reply="ALLOW"><service>~/pause</service></services>
//!         </profile>
//!       </profiles>
//!     </enclave>
//!   </enclaves>
//! </policy>
//! ```
//!
//! [`permissions_xml`] translates one enclave into an OMG DDS Security permissions document
//! (`omg_shared_ca_permissions.xsd`) exactly as sros2's `permissions.xsl` does:
//! - names resolve as ROS 2 resolves them against the profile's `ns` and `node` (`/a` as is,
//!   `~/a` → `<ns>/<node>/a`, `a` → `<ns>/a`) and are mangled as ROS 2 names DDS topics:
//!   a topic `/t` is `rt/t`; a service `/s` is the request topic `rq/sRequest` and the reply
//!   topic `rr/sReply` (`request` = publish requests, subscribe replies; `reply` = the
//!   reverse); an action `/a` is its three services under `/a/_action/` (`send_goal`,
//!   `cancel_goal`, `get_result`) and the topics `rt/a/_action/{feedback,status}` (`call`:
//!   publish requests, subscribe replies, feedback and status; `execute`: the reverse);
//! - one `<grant name="<enclave>">` per `<profiles>` with `<subject_name>CN=<enclave>`, the
//!   validity of the enclave's certificate, a `<deny_rule>` if anything is `DENY`, an
//!   `<allow_rule>` if anything is `ALLOW` (each with the domain and one sorted, duplicate-free
//!   `<publish>` and `<subscribe>` list), an `<allow_rule>` for `ros_discovery_info` (the graph
//!   topic every rmw but Connext's — and ros2-client — publishes, which sros2 adds for them),
//!   and `<default>DENY</default>`.
//!
//! `xi:include` (sros2's shared profiles such as `common/node.xml`) is not supported: a policy
//! with one is refused, naming the line; inline the included elements.
//!
//! [`governance_xml`] is sros2's default governance: no unauthenticated participant, join
//! access control, discovery and liveliness encrypted, RTPS messages signed, and every topic
//! access-controlled with data and metadata encrypted (AES-GCM-GMAC).

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::Path;

use super::error::SecurityError;

/// The policy schema version sros2 reads and writes.
pub const POLICY_VERSION: &str = "0.2.0";

/// `ALLOW` or `DENY`, a rule's qualifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Qualifier {
    /// Permitted.
    Allow,
    /// Forbidden (a deny rule is checked before the allow rules).
    Deny,
}

/// What a list of names is: topics, services or actions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `<topics publish= subscribe=>`.
    Topics,
    /// `<services request= reply=>`.
    Services,
    /// `<actions call= execute=>`.
    Actions,
}

/// One `<topics>`, `<services>` or `<actions>` element of a profile.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rule {
    /// Topics, services or actions.
    pub kind: Kind,
    /// The first role: `publish`, `request` or `call`.
    pub first: Option<Qualifier>,
    /// The second role: `subscribe`, `reply` or `execute`.
    pub second: Option<Qualifier>,
    /// The names as written (absolute, `~/` private or relative; `*` wildcards allowed).
    pub names: Vec<String>,
}

/// A `<profile ns= node=>`: the rules of one node.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Profile {
    /// The node's namespace.
    pub ns: String,
    /// The node's name.
    pub node: String,
    /// Its rules, in file order.
    pub rules: Vec<Rule>,
}

/// An `<enclave path=>`: one `Vec<Profile>` per `<profiles>` element (one grant each).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Enclave {
    /// The enclave's name, e.g. `/crossym/node`.
    pub path: String,
    /// The profiles, grouped as in the file.
    pub profiles: Vec<Vec<Profile>>,
}

/// A policy file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Policy {
    /// Its enclaves, in file order.
    pub enclaves: Vec<Enclave>,
}

impl Policy {
    /// Reads and checks a policy file.
    pub fn read(path: &Path) -> Result<Self, SecurityError> {
        let text = std::fs::read_to_string(path).map_err(SecurityError::io(path))?;
        Self::parse(&text, path)
    }

    /// Parses a policy; `path` names the file in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SecurityError> {
        let doc = roxmltree::Document::parse(text).map_err(|e| SecurityError::Policy {
            path: path.to_path_buf(),
            line: e.pos().row,
            message: format!("not XML: {e}"),
        })?;
        let root = doc.root_element();
        if root.tag_name().name() != "policy" {
            let m = format!(
                "the root element is <{}>, not <policy>",
                root.tag_name().name()
            );
            return Err(xml_error(path, root, m));
        }
        if root.attribute("version") != Some(POLICY_VERSION) {
            let m = format!(
                "<policy version=\"{POLICY_VERSION}\"> expected (found {:?})",
                root.attribute("version")
            );
            return Err(xml_error(path, root, m));
        }
        let enclaves_el = only(path, root, "enclaves")?;
        if enclaves_el.len() != 1 {
            let m = "<policy> holds exactly one <enclaves>".to_string();
            return Err(xml_error(path, root, m));
        }
        let mut enclaves = Vec::new();
        for e in only(path, enclaves_el[0], "enclave")? {
            let enclave_path = attr(path, e, "path")?;
            let mut groups = Vec::new();
            for ps in only(path, e, "profiles")? {
                let mut profiles = Vec::new();
                for p in elements(path, ps)? {
                    match p.tag_name().name() {
                        "profile" => profiles.push(profile(path, p)?),
                        "metadata" => {}
                        other => {
                            let m = format!("<{other}> inside <profiles>: only <profile> and <metadata> belong there");
                            return Err(xml_error(path, p, m));
                        }
                    }
                }
                if profiles.is_empty() {
                    let m = "<profiles> needs at least one <profile>".to_string();
                    return Err(xml_error(path, ps, m));
                }
                groups.push(profiles);
            }
            enclaves.push(Enclave {
                path: enclave_path,
                profiles: groups,
            });
        }
        Ok(Self { enclaves })
    }

    /// The enclave `path`, or an error naming the file and the enclaves it has.
    pub fn enclave(&self, path: &str, file: &Path) -> Result<&Enclave, SecurityError> {
        self.enclaves
            .iter()
            .find(|e| e.path == path)
            .ok_or_else(|| SecurityError::PolicyEnclave {
                path: file.to_path_buf(),
                enclave: path.to_string(),
                known: self
                    .enclaves
                    .iter()
                    .map(|e| e.path.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// sros2's default policy for a new enclave (`policy/defaults/policy.xml`): every
    /// topic, service and action, both ways, for any node.
    pub fn allow_all(enclave: &str) -> Enclave {
        let all = |kind| Rule {
            kind,
            first: Some(Qualifier::Allow),
            second: Some(Qualifier::Allow),
            names: vec!["/*".into()],
        };
        Enclave {
            path: enclave.to_string(),
            profiles: vec![vec![Profile {
                ns: "/".into(),
                node: "default".into(),
                rules: vec![all(Kind::Topics), all(Kind::Services), all(Kind::Actions)],
            }]],
        }
    }
}

/// A [`SecurityError::Policy`] at `node`'s line.
fn xml_error(path: &Path, node: roxmltree::Node, message: String) -> SecurityError {
    SecurityError::Policy {
        path: path.to_path_buf(),
        line: node.document().text_pos_at(node.range().start).row,
        message,
    }
}

/// The child elements of `n`; an `xi:include` among them is refused.
fn elements<'a, 'i>(
    path: &Path,
    n: roxmltree::Node<'a, 'i>,
) -> Result<Vec<roxmltree::Node<'a, 'i>>, SecurityError> {
    let mut out = Vec::new();
    for c in n.children().filter(|c| c.is_element()) {
        let xinclude = c
            .tag_name()
            .namespace()
            .is_some_and(|ns| ns.contains("XInclude"));
        if xinclude || c.tag_name().name() == "include" {
            let m = "xi:include is not supported: write the included elements into the policy";
            return Err(xml_error(path, c, m.into()));
        }
        out.push(c);
    }
    Ok(out)
}

/// The child elements of `n`, at least one, all named `name`.
fn only<'a, 'i>(
    path: &Path,
    n: roxmltree::Node<'a, 'i>,
    name: &str,
) -> Result<Vec<roxmltree::Node<'a, 'i>>, SecurityError> {
    let children = elements(path, n)?;
    let parent = n.tag_name().name();
    if let Some(c) = children.iter().find(|c| c.tag_name().name() != name) {
        let m = format!(
            "<{}> inside <{parent}>: only <{name}> belongs there",
            c.tag_name().name()
        );
        return Err(xml_error(path, *c, m));
    }
    if children.is_empty() {
        return Err(xml_error(
            path,
            n,
            format!("<{parent}> needs at least one <{name}>"),
        ));
    }
    Ok(children)
}

/// The attribute `a` of `n`, which must be there.
fn attr(path: &Path, n: roxmltree::Node, a: &str) -> Result<String, SecurityError> {
    n.attribute(a).map(str::to_string).ok_or_else(|| {
        let m = format!("<{}> needs the attribute {a}=", n.tag_name().name());
        xml_error(path, n, m)
    })
}

/// A `<profile ns= node=>` and its rules.
fn profile(path: &Path, p: roxmltree::Node) -> Result<Profile, SecurityError> {
    let (ns, node) = (attr(path, p, "ns")?, attr(path, p, "node")?);
    let mut rules = Vec::new();
    for r in elements(path, p)? {
        let (kind, item, roles) = match r.tag_name().name() {
            "topics" => (Kind::Topics, "topic", ["publish", "subscribe"]),
            "services" => (Kind::Services, "service", ["request", "reply"]),
            "actions" => (Kind::Actions, "action", ["call", "execute"]),
            other => {
                let m = format!("<{other}> inside <profile>: only <topics>, <services> and <actions> belong there");
                return Err(xml_error(path, r, m));
            }
        };
        for a in r.attributes() {
            if a.namespace().is_none() && !roles.contains(&a.name()) {
                let m = format!(
                    "<{}> has no attribute {}= (only {} and {})",
                    r.tag_name().name(),
                    a.name(),
                    roles[0],
                    roles[1]
                );
                return Err(xml_error(path, r, m));
            }
        }
        let qualifier = |role: &str| match r.attribute(role) {
            None => Ok(None),
            Some("ALLOW") => Ok(Some(Qualifier::Allow)),
            Some("DENY") => Ok(Some(Qualifier::Deny)),
            Some(v) => Err(xml_error(path, r, format!("{role}=\"{v}\": ALLOW or DENY"))),
        };
        let mut names = Vec::new();
        for n in only(path, r, item)? {
            let t = n.text().unwrap_or("").trim();
            if t.is_empty() {
                return Err(xml_error(path, n, format!("empty <{item}>")));
            }
            names.push(t.to_string());
        }
        rules.push(Rule {
            kind,
            first: qualifier(roles[0])?,
            second: qualifier(roles[1])?,
            names,
        });
    }
    Ok(Profile { ns, node, rules })
}

/// A name resolved as sros2's `permissions.xsl` resolves it against a profile.
pub fn resolve(name: &str, ns: &str, node: &str) -> String {
    let ns = if ns.ends_with('/') {
        ns.to_string()
    } else {
        format!("{ns}/")
    };
    if name.starts_with('/') {
        name.to_string()
    } else if let Some(rest) = name.strip_prefix('~') {
        format!("{ns}{node}{rest}")
    } else {
        format!("{ns}{name}")
    }
}

/// The DDS topics a rule's role grants: `(publish, subscribe)`.
fn dds_topics(rule: &Rule, first_role: bool, fqn: &str) -> (Vec<String>, Vec<String>) {
    const ACTION_SERVICES: [&str; 3] = ["cancel_goal", "get_result", "send_goal"];
    let requests = || {
        ACTION_SERVICES
            .iter()
            .map(|s| format!("rq{fqn}/_action/{s}Request"))
    };
    let replies = || {
        ACTION_SERVICES
            .iter()
            .map(|s| format!("rr{fqn}/_action/{s}Reply"))
    };
    let feedback = || {
        [
            format!("rt{fqn}/_action/feedback"),
            format!("rt{fqn}/_action/status"),
        ]
    };
    match (rule.kind, first_role) {
        (Kind::Topics, true) => (vec![format!("rt{fqn}")], vec![]),
        (Kind::Topics, false) => (vec![], vec![format!("rt{fqn}")]),
        (Kind::Services, true) => (
            vec![format!("rq{fqn}Request")],
            vec![format!("rr{fqn}Reply")],
        ),
        (Kind::Services, false) => (
            vec![format!("rr{fqn}Reply")],
            vec![format!("rq{fqn}Request")],
        ),
        (Kind::Actions, true) => (requests().collect(), replies().chain(feedback()).collect()),
        (Kind::Actions, false) => (replies().chain(feedback()).collect(), requests().collect()),
    }
}

/// The sorted, duplicate-free `(publish, subscribe)` DDS topics `qualifier` applies to.
fn rule_topics(profiles: &[Profile], qualifier: Qualifier) -> (BTreeSet<String>, BTreeSet<String>) {
    let (mut publish, mut subscribe) = (BTreeSet::new(), BTreeSet::new());
    for p in profiles {
        for r in &p.rules {
            for (role, q) in [(true, r.first), (false, r.second)] {
                if q != Some(qualifier) {
                    continue;
                }
                for name in &r.names {
                    let (pubs, subs) = dds_topics(r, role, &resolve(name, &p.ns, &p.node));
                    publish.extend(pubs);
                    subscribe.extend(subs);
                }
            }
        }
    }
    (publish, subscribe)
}

/// `&`, `<`, `>` and `"` escaped for XML text and attributes.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn topics_block(out: &mut String, tag: &str, topics: &BTreeSet<String>) {
    if topics.is_empty() {
        return;
    }
    let _ = writeln!(out, "        <{tag}>\n          <topics>");
    for t in topics {
        let _ = writeln!(out, "            <topic>{}</topic>", escape(t));
    }
    let _ = writeln!(out, "          </topics>\n        </{tag}>");
}

fn rule_block(
    out: &mut String,
    tag: &str,
    domain_id: u16,
    publish: &BTreeSet<String>,
    subscribe: &BTreeSet<String>,
) {
    let _ = writeln!(
        out,
        "      <{tag}>\n        <domains>\n          <id>{domain_id}</id>\n        </domains>"
    );
    topics_block(out, "publish", publish);
    topics_block(out, "subscribe", subscribe);
    let _ = writeln!(out, "      </{tag}>");
}

/// The permissions document of `enclave` for domain `domain_id`, valid over `validity`
/// (`YYYY-MM-DDTHH:MM:SS`, the enclave certificate's), as sros2 writes it.
pub fn permissions_xml(enclave: &Enclave, domain_id: u16, validity: (&str, &str)) -> String {
    let mut out = String::from(
        "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" \
         xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd\">\n  <permissions>\n",
    );
    let name = escape(&enclave.path);
    for profiles in &enclave.profiles {
        let _ = writeln!(
            out,
            "    <grant name=\"{name}\">\n      <subject_name>CN={name}</subject_name>\n      <validity>\n        \
             <not_before>{}</not_before>\n        <not_after>{}</not_after>\n      </validity>",
            escape(validity.0),
            escape(validity.1)
        );
        for (q, tag) in [
            (Qualifier::Deny, "deny_rule"),
            (Qualifier::Allow, "allow_rule"),
        ] {
            let has = profiles
                .iter()
                .flat_map(|p| &p.rules)
                .any(|r| r.first == Some(q) || r.second == Some(q));
            if has {
                let (publish, subscribe) = rule_topics(profiles, q);
                rule_block(&mut out, tag, domain_id, &publish, &subscribe);
            }
        }
        let discovery: BTreeSet<String> = ["ros_discovery_info".to_string()].into();
        rule_block(&mut out, "allow_rule", domain_id, &discovery, &discovery);
        out.push_str("      <default>DENY</default>\n    </grant>\n");
    }
    out.push_str("  </permissions>\n</dds>\n");
    out
}

/// sros2's default governance document for domain `domain_id`.
pub fn governance_xml(domain_id: u16) -> String {
    format!(
        r#"<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id>{domain_id}</id>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
"#
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Policy, SecurityError> {
        Policy::parse(text, Path::new("p.xml"))
    }

    #[test]
    fn names_resolve_as_ros_does() {
        assert_eq!(resolve("/joint_states", "/", "crossym"), "/joint_states");
        assert_eq!(resolve("~/status", "/", "crossym"), "/crossym/status");
        assert_eq!(
            resolve("~/status", "/robot1", "crossym"),
            "/robot1/crossym/status"
        );
        assert_eq!(resolve("rosout", "/", "x"), "/rosout");
        assert_eq!(resolve("chatter", "/ns/", "x"), "/ns/chatter");
    }

    /// sros2's talker/listener example: the talker's grant lists exactly the topics sros2's
    /// own expected permissions.xml lists (parameters, /parameter_events, rosout, chatter).
    #[test]
    fn talker_translates_like_sros2() {
        let p = parse(
            r#"<policy version="0.2.0"><enclaves><enclave path="/talker_listener/talker"><profiles>
              <profile ns="/" node="talker">
                <topics publish="ALLOW"><topic>rosout</topic></topics>
                <topics publish="ALLOW" subscribe="ALLOW"><topic>/parameter_events</topic></topics>
                <topics subscribe="ALLOW"><topic>/clock</topic></topics>
                <services reply="ALLOW" request="ALLOW">
                  <service>~/describe_parameters</service><service>~/get_parameter_types</service>
                  <service>~/get_parameters</service><service>~/list_parameters</service>
                  <service>~/set_parameters</service><service>~/set_parameters_atomically</service>
                </services>
                <topics publish="ALLOW"><topic>chatter</topic></topics>
              </profile></profiles></enclave></enclaves></policy>"#,
        )
        .unwrap();
        let e = p
            .enclave("/talker_listener/talker", Path::new("p.xml"))
            .unwrap();
        let (publish, subscribe) = rule_topics(&e.profiles[0], Qualifier::Allow);
        let services = [
            "describe_parameters",
            "get_parameter_types",
            "get_parameters",
            "list_parameters",
            "set_parameters",
            "set_parameters_atomically",
        ];
        let mut want_pub: Vec<String> = services
            .iter()
            .map(|s| format!("rq/talker/{s}Request"))
            .collect();
        want_pub.extend(services.iter().map(|s| format!("rr/talker/{s}Reply")));
        let mut want_sub = want_pub.clone();
        want_pub.extend(["rt/chatter", "rt/parameter_events", "rt/rosout"].map(String::from));
        want_sub.extend(["rt/clock", "rt/parameter_events"].map(String::from));
        assert_eq!(publish.into_iter().collect::<Vec<_>>(), want_pub);
        assert_eq!(subscribe.into_iter().collect::<Vec<_>>(), want_sub);
        let xml = permissions_xml(e, 7, ("2020-05-01T00:00:00", "2030-05-01T00:00:00"));
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let grant = doc.descendants().find(|n| n.has_tag_name("grant")).unwrap();
        assert_eq!(grant.attribute("name"), Some("/talker_listener/talker"));
        let kids: Vec<&str> = grant
            .children()
            .filter(|n| n.is_element())
            .map(|n| n.tag_name().name())
            .collect();
        assert_eq!(
            kids,
            [
                "subject_name",
                "validity",
                "allow_rule",
                "allow_rule",
                "default"
            ]
        );
        assert!(xml.contains("<subject_name>CN=/talker_listener/talker</subject_name>"));
        assert!(xml.contains("<id>7</id>"));
        assert!(xml.contains("<topic>ros_discovery_info</topic>"));
        assert!(!xml.contains("deny_rule"));
    }

    #[test]
    fn deny_comes_first_and_actions_expand() {
        let p = parse(
            r#"<policy version="0.2.0"><enclaves><enclave path="/e"><profiles><profile ns="/ns" node="n">
                <topics publish="DENY"><topic>secret</topic></topics>
                <actions call="ALLOW"><action>~/move</action></actions>
              </profile></profiles></enclave></enclaves></policy>"#,
        )
        .unwrap();
        let e = &p.enclaves[0];
        let (deny_pub, deny_sub) = rule_topics(&e.profiles[0], Qualifier::Deny);
        assert_eq!(deny_pub.into_iter().collect::<Vec<_>>(), ["rt/ns/secret"]);
        assert!(deny_sub.is_empty());
        let (publish, subscribe) = rule_topics(&e.profiles[0], Qualifier::Allow);
        assert_eq!(
            publish.into_iter().collect::<Vec<_>>(),
            [
                "rq/ns/n/move/_action/cancel_goalRequest",
                "rq/ns/n/move/_action/get_resultRequest",
                "rq/ns/n/move/_action/send_goalRequest"
            ]
        );
        assert_eq!(subscribe.len(), 5);
        assert!(subscribe.contains("rt/ns/n/move/_action/feedback"));
        let xml = permissions_xml(e, 0, ("a", "b"));
        assert!(xml.find("<deny_rule>").unwrap() < xml.find("<allow_rule>").unwrap());
    }

    #[test]
    fn bad_policies_are_refused_with_their_line() {
        let cases = [
            ("<policy><enclaves/></policy>", "version"),
            ("<policy version=\"0.2.0\">\n<enclaves>\n<enclave/></enclaves></policy>", "p.xml:3: <enclave> needs the attribute path="),
            (
                "<policy version=\"0.2.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\"><enclaves><enclave path=\"/e\"><profiles><profile ns=\"/\" node=\"n\">\n<xi:include href=\"common/node.xml\"/></profile></profiles></enclave></enclaves></policy>",
                "p.xml:2: xi:include is not supported",
            ),
            (
                "<policy version=\"0.2.0\"><enclaves><enclave path=\"/e\"><profiles><profile ns=\"/\" node=\"n\"><topics publish=\"YES\"><topic>a</topic></topics></profile></profiles></enclave></enclaves></policy>",
                "publish=\"YES\": ALLOW or DENY",
            ),
            (
                "<policy version=\"0.2.0\"><enclaves><enclave path=\"/e\"><profiles><profile ns=\"/\" node=\"n\"><topics read=\"ALLOW\"><topic>a</topic></topics></profile></profiles></enclave></enclaves></policy>",
                "no attribute read=",
            ),
            ("not xml", "not XML"),
        ];
        for (text, want) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(want), "{text}: {e}");
        }
        let p = parse("<policy version=\"0.2.0\"><enclaves><enclave path=\"/a\"><profiles><profile ns=\"/\" node=\"n\"/></profiles></enclave></enclaves></policy>").unwrap();
        let e = p.enclave("/b", Path::new("p.xml")).unwrap_err().to_string();
        assert!(
            e.contains("no <enclave path=\"/b\">") && e.contains("/a"),
            "{e}"
        );
    }

    #[test]
    fn governance_has_the_domain_and_sros2s_protection() {
        let g = governance_xml(42);
        let doc = roxmltree::Document::parse(&g).unwrap();
        let text = |tag: &str| {
            doc.descendants()
                .find(|n| n.has_tag_name(tag))
                .and_then(|n| n.text())
                .unwrap()
        };
        assert_eq!(text("id"), "42");
        assert_eq!(text("allow_unauthenticated_participants"), "false");
        assert_eq!(text("rtps_protection_kind"), "SIGN");
        assert_eq!(text("data_protection_kind"), "ENCRYPT");
    }
}
