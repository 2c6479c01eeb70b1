//! The bridge's side of the ROS 2 graph: the DDS participant (in the configured domain, on one interface
//! if asked), the `vservo` node in the namespace, a publisher for each topic configured and the services
//! (`crate::services` answers them).

use ros2_client::{
    Context, MessageTypeName, Name, Node, Publisher, QosProfile, Server, ServiceMapping, ServiceTypeName,
};
use vservo_config::{Ros2, Ros2Topic};
use vservo_ros2::msg::{
    CameraInfo, DiagnosticArray, Float64MultiArray, Image, JointState, MarkerArray, RosType,
    SetTargetFeaturesRequest, SetTargetPoseRequest, SetTargetResponse, TfMessage, TriggerRequest,
    TriggerResponse, TwistStamped,
};
use vservo_ros2::translate::RosMessage;
use vservo_ros2::{names, qos};

/// A `std_srvs/Trigger` server.
pub type TriggerServer = Server<TriggerRequest, TriggerResponse>;

/// The publishers (each only if configured) and the services.
pub struct Graph {
    pub joint_states: Option<Publisher<JointState>>,
    pub tf: Option<Publisher<TfMessage>>,
    pub tf_static: Option<Publisher<TfMessage>>,
    pub image: Option<Publisher<Image>>,
    pub camera_info: Option<Publisher<CameraInfo>>,
    pub features: Option<Publisher<Float64MultiArray>>,
    pub camera_twist: Option<Publisher<TwistStamped>>,
    pub diagnostics: Option<Publisher<DiagnosticArray>>,
    pub obstacles: Option<Publisher<MarkerArray>>,
    pub safe_stop: TriggerServer,
    pub resume: TriggerServer,
    pub set_target_features: Server<SetTargetFeaturesRequest, SetTargetResponse>,
    pub set_target_pose: Server<SetTargetPoseRequest, SetTargetResponse>,
    /// Kept alive with its entities.
    _node: Node,
    _context: Context,
}

impl Graph {
    /// Joins the domain and creates the node, its publishers and its services.
    pub fn open(settings: &Ros2) -> anyhow::Result<Self> {
        let (context, mut node) = vservo_ros2::domain::node(settings, names::NODE)?;
        let mut maker = Maker { node: &mut node, settings };
        let graph = Self {
            joint_states: maker.publisher(Ros2Topic::JointStates, qos::STREAMS)?,
            tf: maker.publisher(Ros2Topic::Tf, qos::TF)?,
            tf_static: maker.publisher(Ros2Topic::TfStatic, qos::TF_STATIC)?,
            image: maker.publisher(Ros2Topic::Image, qos::STREAMS)?,
            camera_info: maker.publisher(Ros2Topic::CameraInfo, qos::STREAMS)?,
            features: maker.publisher(Ros2Topic::Features, qos::STREAMS)?,
            camera_twist: maker.publisher(Ros2Topic::CameraTwist, qos::STREAMS)?,
            diagnostics: maker.publisher(Ros2Topic::Diagnostics, qos::RELIABLE)?,
            obstacles: maker.publisher(Ros2Topic::Obstacles, qos::TF_STATIC)?,
            safe_stop: maker.server(names::SAFE_STOP, "std_srvs", "Trigger")?,
            resume: maker.server(names::RESUME, "std_srvs", "Trigger")?,
            set_target_features: maker.server(
                names::SET_TARGET_FEATURES,
                "vservo_msgs",
                "SetTargetFeatures",
            )?,
            set_target_pose: maker.server(names::SET_TARGET_POSE, "vservo_msgs", "SetTargetPose")?,
            _node: node,
            _context: context,
        };
        Ok(graph)
    }

    /// Publishes a message on its topic if the topic is configured; `Err` when DDS refused it (a reliable
    /// window full).
    pub fn publish(&self, message: RosMessage) -> Result<(), ()> {
        fn on<T: serde::Serialize>(publisher: &Option<Publisher<T>>, message: T) -> Result<(), ()> {
            match publisher {
                Some(publisher) => publisher.publish(message).map_err(|_| ()),
                None => Ok(()),
            }
        }
        match message {
            RosMessage::JointState(m) => on(&self.joint_states, m),
            RosMessage::Tf(m) => on(&self.tf, m),
            RosMessage::TfStatic(m) => on(&self.tf_static, m),
            RosMessage::Image(m) => on(&self.image, m),
            RosMessage::CameraInfo(m) => on(&self.camera_info, *m),
            RosMessage::Features(m) => on(&self.features, m),
            RosMessage::CameraTwist(m) => on(&self.camera_twist, m),
            RosMessage::Diagnostics(m) => on(&self.diagnostics, m),
            RosMessage::Obstacles(m) => on(&self.obstacles, m),
        }
    }
}

struct Maker<'a> {
    node: &'a mut Node,
    settings: &'a Ros2,
}

impl Maker<'_> {
    /// A publisher on `topic` if the configuration publishes it.
    fn publisher<T: RosType>(
        &mut self,
        topic: Ros2Topic,
        qos: QosProfile,
    ) -> anyhow::Result<Option<Publisher<T>>> {
        if !self.settings.publish.contains(&topic) {
            return Ok(None);
        }
        let qos = qos::as_written(qos, self.settings.qos_of(topic));
        let name = self.name(names::topic(topic))?;
        let ros_topic = self
            .node
            .create_topic(&name, MessageTypeName::new(T::PACKAGE, T::NAME), &qos)
            .map_err(|e| anyhow::anyhow!("creating the topic {}: {e:?}", names::topic(topic)))?;
        let publisher = self
            .node
            .create_publisher::<T>(&ros_topic, None)
            .map_err(|e| anyhow::anyhow!("creating the publisher of {}: {e:?}", names::topic(topic)))?;
        Ok(Some(publisher))
    }

    /// A service of type `package/name`, with the request/reply mapping of ROS 2 on Cyclone DDS.
    fn server<Q: ros2_client::Message + Clone + 'static, A: ros2_client::Message + 'static>(
        &mut self,
        relative: &str,
        package: &str,
        type_name: &str,
    ) -> anyhow::Result<Server<Q, A>> {
        let name = self.name(relative)?;
        self.node
            .create_server::<Q, A>(
                ServiceMapping::Cyclone,
                &name,
                &ServiceTypeName::new(package, type_name),
                qos::SERVICES,
                qos::SERVICES,
            )
            .map_err(|e| anyhow::anyhow!("creating the service {relative}: {e:?}"))
    }

    /// A name in the namespace, absolute.
    fn name(&self, relative: &str) -> anyhow::Result<Name> {
        let absolute = names::absolute(&self.settings.namespace, relative);
        Name::parse(&absolute).map_err(|e| anyhow::anyhow!("the ROS name {absolute:?}: {e:?}"))
    }
}
