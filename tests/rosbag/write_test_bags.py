#!/usr/bin/python3
"""Writes the ROS 1 bags the draco_rosbag tests read, with the official writer.

Uses python3-rosbag (Debian) and genpy's dynamic message generation from the message
definitions below (the same text a recording stores in each connection), so no ROS
message packages are needed. The values are a pure function of the indices below; the
C++ tests (rosbag_test.cpp) recompute them. Usage: write_test_bags.py OUT_DIR
"""

import io
import math
import os
import sys

import genpy
import genpy.dynamic
import rosbag
from PIL import Image

SEPARATOR = "=" * 80 + "\n"

HEADER = """uint32 seq
time stamp
string frame_id
"""
COMPRESSED_IMAGE = """Header header
string format
uint8[] data
"""
IMAGE = """Header header
uint32 height
uint32 width
string encoding
uint8 is_bigendian
uint32 step
uint8[] data
"""
OCULUS_FIRE = """Header header
uint8 mode
uint8 gamma
uint8 flags
float64 range
float64 gain
float64 speed_of_sound
float64 salinity
"""
VECTOR3 = "float64 x\nfloat64 y\nfloat64 z\n"
POINT = "float64 x\nfloat64 y\nfloat64 z\n"
QUATERNION = "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"


def ping_definition(image_type, with_part_number):
    part = "uint16 part_number\n" if with_part_number else ""
    return ("Header header\nOculusFire fire_msg\nuint32 ping_id\n" + part +
            "uint32 start_time\nint16[] bearings\nfloat64 range_resolution\n"
            "uint32 num_ranges\nuint32 num_beams\n" + image_type + " ping\n")


def full_text(main, deps):
    """The connection's message_definition: main text, then each dependency as MSG: section."""
    text = main
    for name, body in deps:
        text += SEPARATOR + "MSG: " + name + "\n" + body
    return text


def make_class(type_name, main, deps):
    return genpy.dynamic.generate_dynamic(type_name, full_text(main, deps))[type_name]


OculusPing = make_class(
    "sonar_oculus/OculusPing",
    ping_definition("sensor_msgs/CompressedImage", True),
    [("std_msgs/Header", HEADER), ("sonar_oculus/OculusFire", OCULUS_FIRE),
     ("sensor_msgs/CompressedImage", COMPRESSED_IMAGE)])
OculusPingOld = make_class(
    "sonar_oculus/OculusPing",
    ping_definition("sensor_msgs/CompressedImage", False),
    [("std_msgs/Header", HEADER), ("sonar_oculus/OculusFire", OCULUS_FIRE),
     ("sensor_msgs/CompressedImage", COMPRESSED_IMAGE)])
OculusPingUncompressed = make_class(
    "sonar_oculus/OculusPingUncompressed",
    ping_definition("sensor_msgs/Image", True),
    [("std_msgs/Header", HEADER), ("sonar_oculus/OculusFire", OCULUS_FIRE),
     ("sensor_msgs/Image", IMAGE)])
Imu = make_class(
    "sensor_msgs/Imu",
    "Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
    "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
    "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n",
    [("std_msgs/Header", HEADER), ("geometry_msgs/Quaternion", QUATERNION),
     ("geometry_msgs/Vector3", VECTOR3)])
Dvl = make_class(
    "rti_dvl/DVL",
    "Header header\ngeometry_msgs/Vector3 velocity\nfloat64 temperature\nfloat64 altitude\n"
    "float64 time\n",
    [("std_msgs/Header", HEADER), ("geometry_msgs/Vector3", VECTOR3)])
Depth = make_class(
    "bar30_depth/Depth",
    "Header header\nfloat32 time\nfloat32 pressure_abs\nfloat32 pressure_diff\n"
    "float32 temperature\nfloat32 depth\n",
    [("std_msgs/Header", HEADER)])
PoseStamped = make_class(
    "geometry_msgs/PoseStamped",
    "# A Pose with reference coordinate frame and timestamp\nHeader header\nPose pose\n",
    [("std_msgs/Header", HEADER),
     ("geometry_msgs/Pose", "Point position\nQuaternion orientation\n"),
     ("geometry_msgs/Point", POINT), ("geometry_msgs/Quaternion", QUATERNION)])
String = make_class("std_msgs/String", "string data\n", [])

# Known values (mirrored in rosbag_test.cpp).
BAG_START = 1600000000.0
RECEIPT_DELAY = 0.005  # receipt (bag) time = header stamp + this
NUM_RANGES = 48
NUM_BEAMS = 32
RANGE_RESOLUTION = 0.05
GAMMA = 127


def pattern(ping, r, c):
    """8x8 blocks of one value each, so JPEG keeps them almost exactly."""
    return (40 * (r // 8) + 25 * (c // 8) + 30 * ping) % 256


def bearing_hundredths(c):
    return int(round(-6500 + c * 13000.0 / (NUM_BEAMS - 1)))


def quaternion(roll, pitch, yaw):
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def stamp(t):
    return genpy.Time.from_sec(BAG_START + t)


def fill_header(header, seq, t, frame):
    header.seq = seq
    header.stamp = stamp(t)
    header.frame_id = frame


def fill_ping_common(msg, k, t, with_part_number=True):
    fill_header(msg.header, k, t, "sonar")
    fill_header(msg.fire_msg.header, k, t, "sonar")
    msg.fire_msg.mode = 1
    msg.fire_msg.gamma = GAMMA
    msg.fire_msg.flags = 25
    msg.fire_msg.range = NUM_RANGES * RANGE_RESOLUTION
    msg.fire_msg.gain = 20.0
    msg.fire_msg.speed_of_sound = 1500.0
    msg.fire_msg.salinity = 0.0
    msg.ping_id = 100 + k
    if with_part_number:
        msg.part_number = 0
    msg.start_time = 1000 * k
    msg.bearings = [bearing_hundredths(c) for c in range(NUM_BEAMS)]
    msg.range_resolution = RANGE_RESOLUTION
    msg.num_ranges = NUM_RANGES
    msg.num_beams = NUM_BEAMS


def pixels(k):
    return bytes(pattern(k, r, c) for r in range(NUM_RANGES) for c in range(NUM_BEAMS))


def jpeg(k):
    img = Image.frombytes("L", (NUM_BEAMS, NUM_RANGES), pixels(k))
    out = io.BytesIO()
    img.save(out, format="JPEG", quality=95)
    return out.getvalue()


def compressed_ping(k, t, cls=OculusPing, with_part_number=True):
    msg = cls()
    fill_ping_common(msg, k, t, with_part_number)
    fill_header(msg.ping.header, k, t, "sonar")
    msg.ping.format = "8UC1; jpeg compressed "
    msg.ping.data = jpeg(k)
    return msg


def uncompressed_ping(k, t):
    msg = OculusPingUncompressed()
    fill_ping_common(msg, k, t)
    fill_header(msg.ping.header, k, t, "sonar")
    msg.ping.height = NUM_RANGES
    msg.ping.width = NUM_BEAMS
    msg.ping.encoding = "mono8"
    msg.ping.is_bigendian = 0
    msg.ping.step = NUM_BEAMS
    msg.ping.data = pixels(k)
    return msg


def imu(k, t):
    msg = Imu()
    fill_header(msg.header, k, t, "imu")
    q = quaternion(0.1, -0.2, 1.0 + 0.1 * k)
    msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = q
    msg.angular_velocity.x = 0.01
    msg.angular_velocity.y = 0.02
    msg.angular_velocity.z = 0.05
    msg.linear_acceleration.z = 9.81
    return msg


def dvl(k, t):
    msg = Dvl()
    fill_header(msg.header, k, t, "dvl")
    msg.velocity.x = 0.5
    msg.velocity.y = -0.1
    msg.velocity.z = 0.02
    msg.temperature = 12.5
    msg.altitude = 3.0 + 0.1 * k
    msg.time = t
    return msg


def depth(k, t):
    msg = Depth()
    fill_header(msg.header, k, t, "depth")
    msg.time = t
    msg.pressure_abs = 1200.0
    msg.depth = 2.0 + 0.25 * k  # exact in float32
    return msg


def pose(k, t):
    msg = PoseStamped()
    fill_header(msg.header, k, t, "world")
    msg.pose.position.x = 1.0 * k
    msg.pose.position.y = 2.0 * k
    msg.pose.position.z = -3.0
    q = quaternion(0.0, 0.0, 0.3)
    msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z, \
        msg.pose.orientation.w = q
    return msg


def write(bag, topic, msg, t):
    bag.write(topic, msg, stamp(t + RECEIPT_DELAY))


def write_full(path, compression=rosbag.Compression.NONE):
    """0.5 s of every stream: 3 pings (5 Hz), 10 IMU (20 Hz), 3 DVL (5 Hz), 5 depth and
    5 ground-truth (10 Hz), and one unrelated topic."""
    events = []
    for k in range(3):
        events.append((0.2 * k, "/sonar_oculus_node/M750d/ping", compressed_ping(k, 0.2 * k)))
        events.append((0.2 * k + 0.001, "/rti/body_velocity/raw", dvl(k, 0.2 * k + 0.001)))
    for k in range(10):
        events.append((0.05 * k + 0.002, "/vn100/imu/raw", imu(k, 0.05 * k + 0.002)))
    for k in range(5):
        events.append((0.1 * k + 0.003, "/bar30/depth/raw", depth(k, 0.1 * k + 0.003)))
        events.append((0.1 * k + 0.004, "/pose_true", pose(k, 0.1 * k + 0.004)))
    other = String()
    other.data = "not read"
    events.append((0.25, "/rosout_like", other))
    events.sort(key=lambda e: e[0])
    with rosbag.Bag(path, "w", compression=compression, chunk_threshold=4096) as bag:
        for t, topic, msg in events:
            write(bag, topic, msg, t)


def write_uncompressed_ping(path):
    with rosbag.Bag(path, "w") as bag:
        for k in range(2):
            write(bag, "/sonar_oculus_node/ping", uncompressed_ping(k, 0.2 * k), 0.2 * k)


def write_old_layout(path):
    with rosbag.Bag(path, "w") as bag:
        for k in range(2):
            msg = compressed_ping(k, 0.2 * k, OculusPingOld, with_part_number=False)
            write(bag, "/sonar_oculus_node/ping", msg, 0.2 * k)


def serialized(msg):
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def write_raw(bag, topic, cls, data, t):
    bag.write(topic, (cls._type, data, cls._md5sum, cls), stamp(t), raw=True)


def write_truncated_message(path):
    """A valid bag whose second ping message is cut inside the bearings array."""
    with rosbag.Bag(path, "w") as bag:
        write(bag, "/sonar_oculus_node/M750d/ping", compressed_ping(0, 0.0), 0.0)
        data = serialized(compressed_ping(1, 0.2))
        bearings_start = data.index(bytes([NUM_BEAMS, 0, 0, 0]) +
                                    bearing_hundredths(0).to_bytes(2, "little", signed=True))
        write_raw(bag, "/sonar_oculus_node/M750d/ping", OculusPing,
                  data[:bearings_start + 4 + 10], 0.2)


def write_bad_jpeg(path):
    with rosbag.Bag(path, "w") as bag:
        msg = compressed_ping(0, 0.0)
        msg.ping.data = b"this is not a jpeg image"
        write(bag, "/sonar_oculus_node/M750d/ping", msg, 0.0)


def write_bad_geometry(path):
    """Bearing table shorter than the image is wide."""
    with rosbag.Bag(path, "w") as bag:
        msg = compressed_ping(0, 0.0)
        msg.bearings = msg.bearings[:10]
        write(bag, "/sonar_oculus_node/M750d/ping", msg, 0.0)


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    write_full(os.path.join(out, "full.bag"))
    write_full(os.path.join(out, "lz4.bag"), rosbag.Compression.LZ4)
    write_full(os.path.join(out, "bz2.bag"), rosbag.Compression.BZ2)
    write_uncompressed_ping(os.path.join(out, "uncompressed_ping.bag"))
    write_old_layout(os.path.join(out, "old_layout.bag"))
    write_truncated_message(os.path.join(out, "truncated_message.bag"))
    write_bad_jpeg(os.path.join(out, "bad_jpeg.bag"))
    write_bad_geometry(os.path.join(out, "bad_geometry.bag"))
    with open(os.path.join(out, "full.bag"), "rb") as f:
        whole = f.read()
    with open(os.path.join(out, "truncated_file.bag"), "wb") as f:
        f.write(whole[:len(whole) * 6 // 10])
    with open(os.path.join(out, "not_a_bag.bag"), "wb") as f:
        f.write(b"#ROSBAG V2.0\n" + bytes((i * 37 + 11) % 256 for i in range(5000)))
    with open(os.path.join(out, "md5.txt"), "w") as f:
        f.write("sonar_oculus/OculusPing %s\n" % OculusPing._md5sum)
        f.write("sonar_oculus/OculusPing(old) %s\n" % OculusPingOld._md5sum)


if __name__ == "__main__":
    main()
