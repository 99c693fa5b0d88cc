//! Split bags: one bag directory holding several storage files, as `ros2 bag record
//! --max-bag-size`/`--max-bag-duration` writes it (`<name>_0.mcap`, `<name>_1.mcap`, …,
//! listed in `metadata.yaml`'s `relative_file_paths`). The files are read one by one and
//! merged into one [`Bag`]: topics matched by name (a topic recorded with two types is
//! refused), messages of all files in one log-time order (stable: ties keep the files'
//! order, then each file's own order).

use std::path::{Path, PathBuf};

use super::content::{Bag, TopicInfo};
use super::BagError;

/// The files' order: by the number after the last `_` of the stem (`bag_2` before
/// `bag_10`), then by name.
pub(crate) fn sort_parts(files: &mut [PathBuf]) {
    let index = |p: &PathBuf| {
        p.file_stem()
            .and_then(|s| s.to_str())
            .and_then(|s| s.rsplit_once('_'))
            .and_then(|(_, n)| n.parse::<u64>().ok())
    };
    files.sort_by(|a, b| index(a).cmp(&index(b)).then_with(|| a.cmp(b)));
}

/// Merges the parts `bags` (read from `dir`, in file order) into one bag labelled `dir`.
pub(crate) fn merge(dir: &Path, bags: Vec<Bag>) -> Result<Bag, BagError> {
    let refuse = |message: String| BagError::NotRos2 {
        path: dir.to_path_buf(),
        message,
    };
    let Some(storage) = bags.first().map(|b| b.storage) else {
        return Err(refuse("a split bag without storage files".into()));
    };
    let mut topics: Vec<TopicInfo> = Vec::new();
    let mut messages = Vec::with_capacity(bags.iter().map(|b| b.messages.len()).sum());
    for part in bags {
        if part.storage != storage {
            return Err(refuse(format!(
                "a split bag mixes storages: {} is {}, the first file {}",
                part.path.display(),
                part.storage.id(),
                storage.id()
            )));
        }
        // This part's topic index → the merged bag's.
        let mut map = Vec::with_capacity(part.topics.len());
        for t in part.topics {
            let k = match topics.iter().position(|u| u.name == t.name) {
                Some(k) if topics[k].ros_type != t.ros_type => {
                    return Err(refuse(format!(
                        "topic {} is {} in {} but {} in an earlier file",
                        t.name,
                        t.ros_type,
                        part.path.display(),
                        topics[k].ros_type
                    )))
                }
                Some(k) => {
                    topics[k].count += t.count;
                    if topics[k].qos.is_none() {
                        topics[k].qos = t.qos;
                    }
                    k
                }
                None => {
                    topics.push(t);
                    topics.len() - 1
                }
            };
            map.push(k);
        }
        messages.extend(part.messages.into_iter().map(|mut m| {
            m.topic = map[m.topic];
            m
        }));
    }
    messages.sort_by_key(|m| m.log_ns);
    Ok(Bag {
        path: dir.to_path_buf(),
        storage,
        topics,
        messages,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bag::{RawMessage, Storage};

    fn part(name: &str, storage: Storage, topics: &[(&str, &str)], msgs: &[(usize, u64)]) -> Bag {
        Bag {
            path: PathBuf::from(name),
            storage,
            topics: topics
                .iter()
                .enumerate()
                .map(|(k, (n, ty))| TopicInfo {
                    name: n.to_string(),
                    ros_type: ty.to_string(),
                    count: msgs.iter().filter(|m| m.0 == k).count(),
                    qos: None,
                })
                .collect(),
            messages: msgs
                .iter()
                .map(|&(topic, log_ns)| RawMessage {
                    topic,
                    log_ns,
                    publish_ns: log_ns,
                    sequence: 0,
                    data: vec![log_ns as u8],
                })
                .collect(),
        }
    }

    #[test]
    fn parts_sort_by_their_index_not_their_spelling() {
        let mut f: Vec<PathBuf> = ["b_10.mcap", "b_2.mcap", "b_0.mcap", "b_1.mcap"]
            .iter()
            .map(PathBuf::from)
            .collect();
        sort_parts(&mut f);
        let names: Vec<_> = f.iter().map(|p| p.to_str().unwrap()).collect();
        assert_eq!(names, ["b_0.mcap", "b_1.mcap", "b_2.mcap", "b_10.mcap"]);
    }

    #[test]
    fn topics_merge_by_name_and_messages_by_log_time() {
        let a = part(
            "b_0.mcap",
            Storage::Mcap,
            &[
                ("/js", "sensor_msgs/msg/JointState"),
                ("/x", "std_msgs/msg/String"),
            ],
            &[(0, 10), (1, 11), (0, 20)],
        );
        // Channels in another order in the second file; one message logged before the
        // first file's last (a recorder writes by arrival, stamps may interleave).
        let b = part(
            "b_1.mcap",
            Storage::Mcap,
            &[
                ("/x", "std_msgs/msg/String"),
                ("/js", "sensor_msgs/msg/JointState"),
            ],
            &[(1, 15), (1, 30), (0, 31)],
        );
        let m = merge(Path::new("dir"), vec![a, b]).unwrap();
        assert_eq!(m.path, Path::new("dir"));
        let names: Vec<_> = m
            .topics
            .iter()
            .map(|t| (t.name.as_str(), t.count))
            .collect();
        assert_eq!(names, [("/js", 4), ("/x", 2)]);
        let got: Vec<_> = m.messages.iter().map(|m| (m.topic, m.log_ns)).collect();
        assert_eq!(got, [(0, 10), (1, 11), (0, 15), (0, 20), (0, 30), (1, 31)]);
    }

    #[test]
    fn a_topic_with_two_types_or_two_storages_is_refused() {
        let a = part("b_0.mcap", Storage::Mcap, &[("/js", "a/msg/A")], &[(0, 1)]);
        let b = part("b_1.mcap", Storage::Mcap, &[("/js", "b/msg/B")], &[(0, 2)]);
        let e = merge(Path::new("dir"), vec![a.clone(), b])
            .unwrap_err()
            .to_string();
        assert!(e.contains("/js is b/msg/B in b_1.mcap but a/msg/A"), "{e}");
        let c = part(
            "b_1.db3",
            Storage::Sqlite3,
            &[("/js", "a/msg/A")],
            &[(0, 2)],
        );
        let e = merge(Path::new("dir"), vec![a, c]).unwrap_err().to_string();
        assert!(e.contains("mixes storages"), "{e}");
    }
}
