//! Renaming a node's output topics, for sources whose recorded names clash with the graph's: a
//! bag of a real robot may carry its pose on `/slam/pose`, which the association publishes. A
//! launch file's `bag` node takes `remap = { "/slam/pose" = "/ground_truth/pose" }` and the bag's
//! poses reach the graph under the new name.
//!
//! Both names must be catalogue topics of the same type (the graph's topics are typed by name).

use nrslam_msgs::{topics, Message};
use nrslam_runtime::{InvalidParam, Node, NodeError, NodeResult, Outbox, Tick};

/// A node whose outputs are published under other names.
pub struct RemapOutputs {
    inner: Box<dyn Node>,
    /// (inner name, published name).
    renames: Vec<(&'static str, &'static str)>,
    scratch: Outbox,
}

impl RemapOutputs {
    /// Wraps `inner`, publishing each output `from` of `renames` as `to`. Every `from` must be an
    /// output of `inner`, every `to` a catalogue topic of `from`'s type, and no two outputs may
    /// end up with one name.
    pub fn new(inner: Box<dyn Node>, renames: &[(String, String)]) -> Result<Self, InvalidParam> {
        let outputs = inner.outputs();
        let mut resolved = Vec::with_capacity(renames.len());
        for (from, to) in renames {
            let bad = |problem: String| {
                InvalidParam::new("remap", problem, "FROM = TO with FROM an output of the node and TO a catalogue topic of the same type")
            };
            let from_spec = outputs
                .iter()
                .find(|o| *o == from)
                .and_then(|o| topics::spec(o))
                .ok_or_else(|| {
                    bad(format!(
                        "{from:?} is not an output of the node ({})",
                        outputs.join(", ")
                    ))
                })?;
            let to_spec = match topics::spec(to) {
                Some(s) if s.type_name == from_spec.type_name => s,
                Some(s) => {
                    return Err(bad(format!(
                        "{to:?} carries {}, not {from:?}'s {}",
                        s.type_name, from_spec.type_name
                    )))
                }
                None => {
                    return Err(bad(format!(
                        "{to:?} is not a catalogue topic (`nrslam topics` lists them)"
                    )))
                }
            };
            resolved.push((from_spec.name, to_spec.name));
        }
        let wrapped = Self {
            inner,
            renames: resolved,
            scratch: Outbox::new(),
        };
        let published = wrapped.outputs();
        for (i, name) in published.iter().enumerate() {
            if published[i + 1..].contains(name) {
                return Err(InvalidParam::new(
                    "remap",
                    format!("two outputs would be published as {name}"),
                    "distinct names",
                ));
            }
        }
        Ok(wrapped)
    }

    fn rename(&self, topic: &'static str) -> &'static str {
        self.renames
            .iter()
            .find(|(from, _)| *from == topic)
            .map_or(topic, |(_, to)| to)
    }

    fn forward(&mut self, outbox: &mut Outbox) {
        let drained: Vec<(&'static str, Message)> = self.scratch.drain().collect();
        for (topic, message) in drained {
            outbox.publish(self.rename(topic), message);
        }
    }
}

impl Node for RemapOutputs {
    fn inputs(&self) -> Vec<&'static str> {
        self.inner.inputs()
    }

    fn outputs(&self) -> Vec<&'static str> {
        self.inner
            .outputs()
            .into_iter()
            .map(|t| self.rename(t))
            .collect()
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        let result = self.inner.on_message(topic, message, &mut self.scratch);
        self.forward(outbox);
        result
    }

    fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
        let result = self.inner.tick(&mut self.scratch);
        self.forward(outbox);
        result
    }

    fn on_end(&mut self, outbox: &mut Outbox) -> Result<(), NodeError> {
        let result = self.inner.on_end(&mut self.scratch);
        self.forward(outbox);
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::topics::{CLOCK, GROUND_TRUTH_POSE, ODOM, SLAM_POSE};
    use nrslam_msgs::{Clock, PoseStamped};

    /// Publishes one pose and one clock, then is done.
    struct Source;

    impl Node for Source {
        fn inputs(&self) -> Vec<&'static str> {
            vec![]
        }
        fn outputs(&self) -> Vec<&'static str> {
            vec![SLAM_POSE, CLOCK]
        }
        fn on_message(&mut self, _: &str, _: &Message, _: &mut Outbox) -> Result<(), NodeError> {
            Ok(())
        }
        fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
            outbox.publish(SLAM_POSE, PoseStamped::default());
            outbox.publish(CLOCK, Clock::default());
            Ok(Tick::Done)
        }
    }

    fn remap(pairs: &[(&str, &str)]) -> Result<RemapOutputs, InvalidParam> {
        let pairs: Vec<(String, String)> = pairs
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect();
        RemapOutputs::new(Box::new(Source), &pairs)
    }

    #[test]
    fn renamed_outputs_are_declared_and_published_under_the_new_name() {
        let mut node = remap(&[(SLAM_POSE, GROUND_TRUTH_POSE)]).unwrap();
        assert_eq!(node.outputs(), vec![GROUND_TRUTH_POSE, CLOCK]);
        let mut outbox = Outbox::new();
        assert_eq!(node.tick(&mut outbox).unwrap(), Tick::Done);
        let topics: Vec<_> = outbox.drain().map(|(t, _)| t).collect();
        assert_eq!(topics, vec![GROUND_TRUTH_POSE, CLOCK]);
    }

    #[test]
    fn unknown_names_other_types_and_clashes_are_refused() {
        for (pairs, needle) in [
            (vec![("/nowhere", GROUND_TRUTH_POSE)], "not an output"),
            (vec![(SLAM_POSE, ODOM)], "nav_msgs"),
            (vec![(SLAM_POSE, "/elsewhere")], "not a catalogue topic"),
        ] {
            let err = remap(&pairs).err().expect("refused").to_string();
            assert!(err.contains("remap") && err.contains(needle), "{err}");
        }
        let err = remap(&[(CLOCK, CLOCK), (SLAM_POSE, SLAM_POSE)]);
        assert!(err.is_ok(), "identity renames are harmless");
    }
}
