//! `visualization_msgs/MarkerArray` and what it holds, in the field order of ROS 2 Humble's and Jazzy's `.msg`
//! files (the same fields in both; Jazzy adds the constant `ARROW_STRIP`): the collision guard's obstacles on
//! `vservo/obstacles`.

use serde::{Deserialize, Serialize};

use super::{Definition, Header, Point, Pose, RosType, Vector3};

ros_message! {
    /// `builtin_interfaces/Duration`.
    #[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
    pub struct Duration = "builtin_interfaces" / "Duration" {
        /// Whole seconds.
        sec: i32 = "int32",
        /// Nanoseconds past them.
        nanosec: u32 = "uint32",
    }
}

ros_message! {
    /// `std_msgs/ColorRGBA`: each 0–1.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct ColorRgba = "std_msgs" / "ColorRGBA" {
        /// Red.
        r: f32 = "float32",
        /// Green.
        g: f32 = "float32",
        /// Blue.
        b: f32 = "float32",
        /// Opacity.
        a: f32 = "float32",
    }
}

ros_message! {
    /// `sensor_msgs/CompressedImage` (a marker's texture; empty here).
    #[derive(Debug, Clone, Default, PartialEq, Eq)]
    pub struct CompressedImage = "sensor_msgs" / "CompressedImage" {
        /// When and where.
        header: Header = "std_msgs/Header",
        /// `jpeg` or `png`.
        format: String = "string",
        /// The compressed bytes.
        data: Vec<u8> = "uint8[]",
    }
}

ros_message! {
    /// `visualization_msgs/UVCoordinate`.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct UvCoordinate = "visualization_msgs" / "UVCoordinate" {
        /// u.
        u: f32 = "float32",
        /// v.
        v: f32 = "float32",
    }
}

ros_message! {
    /// `visualization_msgs/MeshFile` (a marker's embedded mesh; empty here).
    #[derive(Debug, Clone, Default, PartialEq, Eq)]
    pub struct MeshFile = "visualization_msgs" / "MeshFile" {
        /// The file's name.
        filename: String = "string",
        /// Its bytes.
        data: Vec<u8> = "uint8[]",
    }
}

ros_message! {
    /// `visualization_msgs/Marker`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct Marker = "visualization_msgs" / "Marker" {
        /// When, and the frame its pose is in.
        header: Header = "std_msgs/Header",
        /// Its namespace (with `id`, what a later marker replaces).
        ns: String = "string",
        /// Its number in the namespace.
        id: i32 = "int32",
        /// [`Marker::CUBE`], … (`type` in the `.msg` file)
        kind as "type": i32 = "int32",
        /// [`Marker::ADD`], …
        action: i32 = "int32",
        /// Its centre and orientation.
        pose: Pose = "geometry_msgs/Pose",
        /// Its size along its axes (m; a line's width in x).
        scale: Vector3 = "geometry_msgs/Vector3",
        /// Its colour.
        color: ColorRgba = "std_msgs/ColorRGBA",
        /// How long it stays (zero: until replaced).
        lifetime: Duration = "builtin_interfaces/Duration",
        /// Whether it moves with its frame.
        frame_locked: bool = "bool",
        /// A line's or a list's points.
        points: Vec<Point> = "geometry_msgs/Point[]",
        /// Their colours.
        colors: Vec<ColorRgba> = "std_msgs/ColorRGBA[]",
        /// A texture's resource.
        texture_resource: String = "string",
        /// A texture.
        texture: CompressedImage = "sensor_msgs/CompressedImage",
        /// A texture's coordinates.
        uv_coordinates: Vec<UvCoordinate> = "visualization_msgs/UVCoordinate[]",
        /// A text's words.
        text: String = "string",
        /// A mesh's resource.
        mesh_resource: String = "string",
        /// An embedded mesh.
        mesh_file: MeshFile = "visualization_msgs/MeshFile",
        /// Whether a mesh keeps its own materials.
        mesh_use_embedded_materials: bool = "bool",
    }
    constants "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\nint32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n";
}

impl Marker {
    /// A box.
    pub const CUBE: i32 = 1;
    /// A ball.
    pub const SPHERE: i32 = 2;
    /// A cylinder along z.
    pub const CYLINDER: i32 = 3;
    /// Segments, a pair of points each.
    pub const LINE_LIST: i32 = 5;
    /// A text that faces the viewer.
    pub const TEXT_VIEW_FACING: i32 = 9;
    /// Add or replace.
    pub const ADD: i32 = 0;
    /// Remove every marker of the topic.
    pub const DELETEALL: i32 = 3;
}

ros_message! {
    /// `visualization_msgs/MarkerArray`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct MarkerArray = "visualization_msgs" / "MarkerArray" {
        /// The markers.
        markers: Vec<Marker> = "visualization_msgs/Marker[]",
    }
}
ros_type!(MarkerArray);
