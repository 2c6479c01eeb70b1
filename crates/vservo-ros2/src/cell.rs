//! The instance's side: a client of its services, which it reads with iceoryx2's safe overflow (a slow
//! bridge loses its oldest samples, it never slows the loop). A service is opened when it exists: the
//! daemon may still be starting, a node may not be up, and a cell without a simulated robot never has some.

use std::time::Duration;

use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ZeroCopySend, ipc};
use vservo_client::{Client, ClientError};
use vservo_protocol::inbox::{Payload, TakeMessages};
use vservo_protocol::{
    CameraImageHeader, CameraTwistMsg, DaemonStatusMsg, FeaturesMsg, JointStateMsg, NodeRole, TelemetryMsg,
    Topic,
};

/// One service's subscriber, once it exists.
struct Tap<T: std::fmt::Debug + ZeroCopySend + 'static> {
    topic: Topic,
    subscriber: Option<Subscriber<ipc::Service, T, ()>>,
}

impl<T: Payload> Tap<T> {
    fn new(topic: Topic) -> Self {
        Self { topic, subscriber: None }
    }

    fn open(&mut self, client: &Client) {
        if self.subscriber.is_none() {
            self.subscriber = client.subscribe::<T>(self.topic).ok();
        }
    }

    /// Every message waiting of this schema; `refused` counts the others.
    fn each(&self, refused: &mut u64, take: impl FnMut(T)) {
        if let Some(subscriber) = &self.subscriber {
            *refused += subscriber.each_message(take);
        }
    }
}

/// The instance's services the bridge reads.
pub struct Cell {
    /// The instance's client: for commands.
    pub client: Client,
    joint_state: Tap<JointStateMsg>,
    features: Tap<FeaturesMsg>,
    camera_twist: Tap<CameraTwistMsg>,
    status: Tap<DaemonStatusMsg>,
    telemetry: Tap<TelemetryMsg>,
    images: Option<Subscriber<ipc::Service, [u8], CameraImageHeader>>,
    /// Messages of another schema, refused (`vservo_protocol::inbox`).
    pub refused: u64,
}

/// What arrived since the last look.
#[derive(Default)]
pub struct Arrived {
    /// The newest joint state.
    pub joint_state: Option<JointStateMsg>,
    /// Every frame's features.
    pub features: Vec<FeaturesMsg>,
    /// Every twist.
    pub twists: Vec<CameraTwistMsg>,
    /// The daemon's newest status.
    pub status: Option<DaemonStatusMsg>,
    /// Each node's newest telemetry.
    pub telemetry: [Option<TelemetryMsg>; 4],
}

impl Cell {
    /// Connects to the instance, waiting for its daemon until `give_up()` says so (`None` then).
    pub fn connect(instance: &str, mut give_up: impl FnMut() -> bool) -> Result<Option<Self>, ClientError> {
        let mut said = false;
        let client = loop {
            match Client::connect(instance) {
                Ok(client) => break client,
                Err(_) if give_up() => return Ok(None),
                Err(error) => {
                    if !said {
                        tracing::info!(instance, %error, "waiting for the instance");
                        said = true;
                    }
                    std::thread::sleep(Duration::from_millis(100));
                }
            }
        };
        let mut cell = Self {
            client,
            joint_state: Tap::new(Topic::JointState),
            features: Tap::new(Topic::Features),
            camera_twist: Tap::new(Topic::CameraTwist),
            status: Tap::new(Topic::Status),
            telemetry: Tap::new(Topic::Telemetry),
            images: None,
            refused: 0,
        };
        cell.open();
        Ok(Some(cell))
    }

    /// Opens the services that exist now and were not open.
    pub fn open(&mut self) {
        self.joint_state.open(&self.client);
        self.features.open(&self.client);
        self.camera_twist.open(&self.client);
        self.status.open(&self.client);
        self.telemetry.open(&self.client);
        if self.images.is_none() {
            self.images = self.client.subscribe_camera_images().ok();
        }
    }

    /// Takes what arrived; the features and twists are kept in order, of the rest the newest.
    pub fn take(&mut self, arrived: &mut Arrived) {
        let refused = &mut self.refused;
        self.joint_state.each(refused, |m| arrived.joint_state = Some(m));
        self.features.each(refused, |m| arrived.features.push(m));
        self.camera_twist.each(refused, |m| arrived.twists.push(m));
        self.status.each(refused, |m| arrived.status = Some(m));
        self.telemetry.each(refused, |m| {
            if let Some(role) = NodeRole::from_index(m.node) {
                arrived.telemetry[role as usize] = Some(m);
            }
        });
    }

    /// Each camera image waiting, to `each` with its header and pixels; one of another schema is refused.
    pub fn each_image(&mut self, mut each: impl FnMut(&CameraImageHeader, &[u8])) -> Result<(), ClientError> {
        let Some(subscriber) = &self.images else { return Ok(()) };
        loop {
            let received = subscriber.receive().map_err(|e| ClientError::Transport {
                what: "reading camera images",
                reason: e.to_string(),
            })?;
            let Some(sample) = received else { return Ok(()) };
            match vservo_protocol::inbox::accept(*sample.user_header()) {
                Ok(header) => each(&header, sample.payload()),
                Err(_) => self.refused += 1,
            }
        }
    }
}
