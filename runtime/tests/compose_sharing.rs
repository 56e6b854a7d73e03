//! In-process composition shares a published message between its subscribers: every subscriber
//! (and the observer) reads the very allocation the publisher moved into its outbox, so a
//! megabyte waveform echo is never copied per subscriber. A deep clone per subscriber would give
//! each one its own payload buffer, and these tests would fail.

use nrslam_msgs::topics::{CLOCK, ECHO};
use nrslam_msgs::{Clock, Header, Message, RadarEcho, Time};
use nrslam_runtime::compose::Graph;
use nrslam_runtime::node::{Node, NodeError, NodeResult, Outbox, Tick};
use std::sync::{Arc, Mutex};

/// Payload length of each echo (f64 values): 8 MB, so a copy is not an accident of small sizes.
const SAMPLES: usize = 1 << 20;

/// Address of the payload buffer of an echo.
fn payload(message: &Message) -> usize {
    match message {
        Message::RadarEcho(echo) => echo.received.as_ptr() as usize,
        other => panic!("expected an echo, got {}", other.type_name()),
    }
}

/// Publishes `frames` echoes and, at the same stamps, clocks; records each echo's payload address.
struct Source {
    frames: u32,
    sent: u32,
    published: Arc<Mutex<Vec<usize>>>,
}

impl Node for Source {
    fn inputs(&self) -> Vec<&'static str> {
        vec![]
    }
    fn outputs(&self) -> Vec<&'static str> {
        vec![ECHO, CLOCK]
    }
    fn on_message(&mut self, _: &str, _: &Message, _: &mut Outbox) -> Result<(), NodeError> {
        Ok(())
    }
    fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
        self.sent += 1;
        let stamp = Time::from_seconds(f64::from(self.sent));
        let echo = RadarEcho {
            header: Header::new(stamp, "radar"),
            received: vec![f64::from(self.sent); SAMPLES],
            ..Default::default()
        };
        self.published
            .lock()
            .unwrap()
            .push(echo.received.as_ptr() as usize);
        // Moving the echo into the message keeps its buffer where it is.
        outbox.publish(ECHO, echo);
        outbox.publish(CLOCK, Clock { clock: stamp });
        Ok(if self.sent == self.frames {
            Tick::Done
        } else {
            Tick::More
        })
    }
}

/// What a subscriber saw: (topic, stamp in s, payload address of an echo or 0).
type Seen = Arc<Mutex<Vec<(String, f64, usize)>>>;

struct Subscriber {
    inputs: Vec<&'static str>,
    seen: Seen,
}

impl Node for Subscriber {
    fn inputs(&self) -> Vec<&'static str> {
        self.inputs.clone()
    }
    fn outputs(&self) -> Vec<&'static str> {
        vec![]
    }
    fn on_message(&mut self, topic: &str, message: &Message, _: &mut Outbox) -> NodeResult {
        let address = if topic == ECHO { payload(message) } else { 0 };
        self.seen
            .lock()
            .unwrap()
            .push((topic.to_owned(), message.stamp().as_seconds(), address));
        Ok(())
    }
}

#[test]
fn every_subscriber_and_the_observer_read_the_published_buffer_itself() {
    const FRAMES: u32 = 4;
    let published = Arc::new(Mutex::new(Vec::new()));
    let subscribers: Vec<Seen> = (0..3).map(|_| Seen::default()).collect();
    let mut nodes: Vec<(String, Box<dyn Node>)> = vec![(
        "source".into(),
        Box::new(Source {
            frames: FRAMES,
            sent: 0,
            published: published.clone(),
        }),
    )];
    for (i, seen) in subscribers.iter().enumerate() {
        nodes.push((
            format!("subscriber{i}"),
            Box::new(Subscriber {
                inputs: vec![ECHO],
                seen: seen.clone(),
            }),
        ));
    }
    let mut observed = Vec::new();
    Graph::new(nodes)
        .run(&mut |topic: &'static str, message: &Message| {
            if topic == ECHO {
                observed.push(payload(message));
            }
        })
        .unwrap();
    let published = published.lock().unwrap().clone();
    assert_eq!(published.len(), FRAMES as usize);
    assert_eq!(
        observed, published,
        "the observer reads the published buffers"
    );
    for (i, seen) in subscribers.iter().enumerate() {
        let addresses: Vec<usize> = seen.lock().unwrap().iter().map(|s| s.2).collect();
        assert_eq!(
            addresses, published,
            "subscriber {i} reads the published buffers, not copies"
        );
    }
}

#[test]
fn shared_messages_keep_the_merged_order_of_several_inputs() {
    // Clock listed first: at equal stamps it is delivered before the echo (input order).
    const FRAMES: u32 = 3;
    let published = Arc::new(Mutex::new(Vec::new()));
    let seen = Seen::default();
    let nodes: Vec<(String, Box<dyn Node>)> = vec![
        (
            "source".into(),
            Box::new(Source {
                frames: FRAMES,
                sent: 0,
                published: published.clone(),
            }),
        ),
        (
            "both".into(),
            Box::new(Subscriber {
                inputs: vec![CLOCK, ECHO],
                seen: seen.clone(),
            }),
        ),
        (
            "echo_only".into(),
            Box::new(Subscriber {
                inputs: vec![ECHO],
                seen: Seen::default(),
            }),
        ),
    ];
    Graph::new(nodes)
        .run(&mut |_: &'static str, _: &Message| {})
        .unwrap();
    let published = published.lock().unwrap().clone();
    let mut expected = Vec::new();
    for (frame, &address) in published.iter().enumerate() {
        let t = (frame + 1) as f64;
        expected.push((CLOCK.to_owned(), t, 0));
        expected.push((ECHO.to_owned(), t, address));
    }
    assert_eq!(*seen.lock().unwrap(), expected);
}
