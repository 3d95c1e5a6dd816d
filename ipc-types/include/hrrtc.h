/* hrrtc wire types: the payloads of the haptic loop's and the planner's iceoryx2
 * services. Generated from ipc-types/src/layout.rs; do not edit. Regenerate with
 * `HRRTC_BLESS=1 cargo test -p ipc-types layout`.
 *
 * Units are SI (m, N, N*m, s, rad); timestamps are CLOCK_MONOTONIC ns;
 * quaternions are [x, y, z, w]; each field's frame is documented on the Rust type. */
#ifndef HRRTC_WIRE_H
#define HRRTC_WIRE_H

#include <stddef.h>
#include <stdint.h>

#define HRRTC_PATH_CAPACITY 512u
#define HRRTC_ROADMAP_NODES 1024u
#define HRRTC_ROADMAP_TREES 64u
#define HRRTC_NO_PARENT 4294967295u
#define HRRTC_DRIVER_NAME_LEN 32u
#define HRRTC_ENTRY_KEY 0u

typedef uint32_t hrrtc_FaultCode;
#define HRRTC_FAULT_CODE_NONE 0u
#define HRRTC_FAULT_CODE_DEVICE_READ 1u
#define HRRTC_FAULT_CODE_DEVICE_WRITE 2u
#define HRRTC_FAULT_CODE_DEVICE_NON_FINITE 3u
#define HRRTC_FAULT_CODE_DEVICE_JUMP 4u
#define HRRTC_FAULT_CODE_DEVICE_STALE 5u
#define HRRTC_FAULT_CODE_DEVICE_DISCONNECTED 6u
#define HRRTC_FAULT_CODE_OVERRUN_STREAK 7u
#define HRRTC_FAULT_CODE_NON_FINITE_WRENCH 8u
#define HRRTC_FAULT_CODE_STARTUP 9u

typedef uint32_t hrrtc_ContactCode;
#define HRRTC_CONTACT_CODE_DISABLED 0u
#define HRRTC_CONTACT_CODE_FREE 1u
#define HRRTC_CONTACT_CODE_PROXIMITY 2u
#define HRRTC_CONTACT_CODE_CONTACT 3u

typedef uint32_t hrrtc_GuidanceMode;
#define HRRTC_GUIDANCE_MODE_NONE 0u
#define HRRTC_GUIDANCE_MODE_ROADMAP 1u
#define HRRTC_GUIDANCE_MODE_PATH 2u
#define HRRTC_GUIDANCE_MODE_NO_WAY 3u

typedef uint32_t hrrtc_GuidanceFreshness;
#define HRRTC_GUIDANCE_FRESHNESS_NONE 0u
#define HRRTC_GUIDANCE_FRESHNESS_FRESH 1u
#define HRRTC_GUIDANCE_FRESHNESS_FADING 2u
#define HRRTC_GUIDANCE_FRESHNESS_LOST 3u

typedef uint32_t hrrtc_TreeKind;
#define HRRTC_TREE_KIND_START 0u
#define HRRTC_TREE_KIND_GOAL 1u
#define HRRTC_TREE_KIND_LOCAL 2u

typedef uint32_t hrrtc_DriverStatus;
#define HRRTC_DRIVER_STATUS_UNKNOWN 0u
#define HRRTC_DRIVER_STATUS_OK 1u
#define HRRTC_DRIVER_STATUS_NOT_READY 2u
#define HRRTC_DRIVER_STATUS_FAULT 3u

typedef uint32_t hrrtc_OutputCode;
#define HRRTC_OUTPUT_CODE_OFF 0u
#define HRRTC_OUTPUT_CODE_ON 1u

/* iceoryx2 type name "hrrtc::Header.v1" */
typedef struct hrrtc_Header {
    uint64_t sequence;
    uint64_t timestamp_ns;
    uint32_t writer_pid;
    uint32_t reserved;
} hrrtc_Header;
_Static_assert(sizeof(hrrtc_Header) == 24, "size of Header");
_Static_assert(_Alignof(hrrtc_Header) == 8, "alignment of Header");
_Static_assert(offsetof(hrrtc_Header, sequence) == 0, "offset of Header.sequence");
_Static_assert(offsetof(hrrtc_Header, timestamp_ns) == 8, "offset of Header.timestamp_ns");
_Static_assert(offsetof(hrrtc_Header, writer_pid) == 16, "offset of Header.writer_pid");
_Static_assert(offsetof(hrrtc_Header, reserved) == 20, "offset of Header.reserved");
#define HRRTC_HEADER_TYPE_NAME "hrrtc::Header.v1"

/* iceoryx2 type name "hrrtc::Pose.v1" */
typedef struct hrrtc_Pose {
    double position_m[3];
    double orientation_xyzw[4];
} hrrtc_Pose;
_Static_assert(sizeof(hrrtc_Pose) == 56, "size of Pose");
_Static_assert(_Alignof(hrrtc_Pose) == 8, "alignment of Pose");
_Static_assert(offsetof(hrrtc_Pose, position_m) == 0, "offset of Pose.position_m");
_Static_assert(offsetof(hrrtc_Pose, orientation_xyzw) == 24, "offset of Pose.orientation_xyzw");
#define HRRTC_POSE_TYPE_NAME "hrrtc::Pose.v1"

/* iceoryx2 type name "hrrtc::Wrench.v1" */
typedef struct hrrtc_Wrench {
    double force_n[3];
    double torque_nm[3];
} hrrtc_Wrench;
_Static_assert(sizeof(hrrtc_Wrench) == 48, "size of Wrench");
_Static_assert(_Alignof(hrrtc_Wrench) == 8, "alignment of Wrench");
_Static_assert(offsetof(hrrtc_Wrench, force_n) == 0, "offset of Wrench.force_n");
_Static_assert(offsetof(hrrtc_Wrench, torque_nm) == 24, "offset of Wrench.torque_nm");
#define HRRTC_WRENCH_TYPE_NAME "hrrtc::Wrench.v1"

/* iceoryx2 type name "hrrtc::Twist.v1" */
typedef struct hrrtc_Twist {
    double linear_m_s[3];
    double angular_rad_s[3];
} hrrtc_Twist;
_Static_assert(sizeof(hrrtc_Twist) == 48, "size of Twist");
_Static_assert(_Alignof(hrrtc_Twist) == 8, "alignment of Twist");
_Static_assert(offsetof(hrrtc_Twist, linear_m_s) == 0, "offset of Twist.linear_m_s");
_Static_assert(offsetof(hrrtc_Twist, angular_rad_s) == 24, "offset of Twist.angular_rad_s");
#define HRRTC_TWIST_TYPE_NAME "hrrtc::Twist.v1"

/* iceoryx2 type name "hrrtc::HapticState.v2" */
typedef struct hrrtc_HapticState {
    hrrtc_Header header;
    hrrtc_Pose device_pose;
    hrrtc_Twist device_twist;
    hrrtc_Pose user_pose;
    hrrtc_Pose proxy_pose;
    hrrtc_Wrench commanded_wrench;
    hrrtc_Wrench contact_wrench;
    hrrtc_Wrench guidance_wrench;
    hrrtc_ContactCode contact;
    hrrtc_FaultCode fault;
    uint32_t buttons;
    hrrtc_GuidanceFreshness guidance_freshness;
    double contact_normal[3];
    double contact_point_m[3];
    double operator_force_n[3];
    double displacement_m[3];
    double penetration_m;
    uint64_t guidance_sequence;
    uint64_t prev_wake_latency_ns;
    uint64_t prev_compute_ns;
    uint64_t prev_period_ns;
    uint64_t deadline_misses;
    uint64_t published_ns;
} hrrtc_HapticState;
_Static_assert(sizeof(hrrtc_HapticState) == 552, "size of HapticState");
_Static_assert(_Alignof(hrrtc_HapticState) == 8, "alignment of HapticState");
_Static_assert(offsetof(hrrtc_HapticState, header) == 0, "offset of HapticState.header");
_Static_assert(offsetof(hrrtc_HapticState, device_pose) == 24, "offset of HapticState.device_pose");
_Static_assert(offsetof(hrrtc_HapticState, device_twist) == 80, "offset of HapticState.device_twist");
_Static_assert(offsetof(hrrtc_HapticState, user_pose) == 128, "offset of HapticState.user_pose");
_Static_assert(offsetof(hrrtc_HapticState, proxy_pose) == 184, "offset of HapticState.proxy_pose");
_Static_assert(offsetof(hrrtc_HapticState, commanded_wrench) == 240, "offset of HapticState.commanded_wrench");
_Static_assert(offsetof(hrrtc_HapticState, contact_wrench) == 288, "offset of HapticState.contact_wrench");
_Static_assert(offsetof(hrrtc_HapticState, guidance_wrench) == 336, "offset of HapticState.guidance_wrench");
_Static_assert(offsetof(hrrtc_HapticState, contact) == 384, "offset of HapticState.contact");
_Static_assert(offsetof(hrrtc_HapticState, fault) == 388, "offset of HapticState.fault");
_Static_assert(offsetof(hrrtc_HapticState, buttons) == 392, "offset of HapticState.buttons");
_Static_assert(offsetof(hrrtc_HapticState, guidance_freshness) == 396, "offset of HapticState.guidance_freshness");
_Static_assert(offsetof(hrrtc_HapticState, contact_normal) == 400, "offset of HapticState.contact_normal");
_Static_assert(offsetof(hrrtc_HapticState, contact_point_m) == 424, "offset of HapticState.contact_point_m");
_Static_assert(offsetof(hrrtc_HapticState, operator_force_n) == 448, "offset of HapticState.operator_force_n");
_Static_assert(offsetof(hrrtc_HapticState, displacement_m) == 472, "offset of HapticState.displacement_m");
_Static_assert(offsetof(hrrtc_HapticState, penetration_m) == 496, "offset of HapticState.penetration_m");
_Static_assert(offsetof(hrrtc_HapticState, guidance_sequence) == 504, "offset of HapticState.guidance_sequence");
_Static_assert(offsetof(hrrtc_HapticState, prev_wake_latency_ns) == 512, "offset of HapticState.prev_wake_latency_ns");
_Static_assert(offsetof(hrrtc_HapticState, prev_compute_ns) == 520, "offset of HapticState.prev_compute_ns");
_Static_assert(offsetof(hrrtc_HapticState, prev_period_ns) == 528, "offset of HapticState.prev_period_ns");
_Static_assert(offsetof(hrrtc_HapticState, deadline_misses) == 536, "offset of HapticState.deadline_misses");
_Static_assert(offsetof(hrrtc_HapticState, published_ns) == 544, "offset of HapticState.published_ns");
#define HRRTC_HAPTIC_STATE_TYPE_NAME "hrrtc::HapticState.v2"

/* iceoryx2 type name "hrrtc::Guidance.v1" */
typedef struct hrrtc_Guidance {
    hrrtc_Header header;
    double attractive[6];
    double gain_n_per_m;
    double gain_nm_per_rad;
    uint64_t time_to_live_ns;
    uint64_t state_sequence;
    hrrtc_GuidanceMode mode;
    uint32_t solved;
    uint64_t iterations;
    uint64_t nodes;
    uint32_t trees;
    uint32_t planner_id;
    double distance_to_goal;
    uint64_t collision_checks;
} hrrtc_Guidance;
_Static_assert(sizeof(hrrtc_Guidance) == 152, "size of Guidance");
_Static_assert(_Alignof(hrrtc_Guidance) == 8, "alignment of Guidance");
_Static_assert(offsetof(hrrtc_Guidance, header) == 0, "offset of Guidance.header");
_Static_assert(offsetof(hrrtc_Guidance, attractive) == 24, "offset of Guidance.attractive");
_Static_assert(offsetof(hrrtc_Guidance, gain_n_per_m) == 72, "offset of Guidance.gain_n_per_m");
_Static_assert(offsetof(hrrtc_Guidance, gain_nm_per_rad) == 80, "offset of Guidance.gain_nm_per_rad");
_Static_assert(offsetof(hrrtc_Guidance, time_to_live_ns) == 88, "offset of Guidance.time_to_live_ns");
_Static_assert(offsetof(hrrtc_Guidance, state_sequence) == 96, "offset of Guidance.state_sequence");
_Static_assert(offsetof(hrrtc_Guidance, mode) == 104, "offset of Guidance.mode");
_Static_assert(offsetof(hrrtc_Guidance, solved) == 108, "offset of Guidance.solved");
_Static_assert(offsetof(hrrtc_Guidance, iterations) == 112, "offset of Guidance.iterations");
_Static_assert(offsetof(hrrtc_Guidance, nodes) == 120, "offset of Guidance.nodes");
_Static_assert(offsetof(hrrtc_Guidance, trees) == 128, "offset of Guidance.trees");
_Static_assert(offsetof(hrrtc_Guidance, planner_id) == 132, "offset of Guidance.planner_id");
_Static_assert(offsetof(hrrtc_Guidance, distance_to_goal) == 136, "offset of Guidance.distance_to_goal");
_Static_assert(offsetof(hrrtc_Guidance, collision_checks) == 144, "offset of Guidance.collision_checks");
#define HRRTC_GUIDANCE_TYPE_NAME "hrrtc::Guidance.v1"

/* iceoryx2 type name "hrrtc::Path.v1" */
typedef struct hrrtc_Path {
    hrrtc_Header header;
    uint64_t len;
    double length;
    hrrtc_Pose waypoints[512];
} hrrtc_Path;
_Static_assert(sizeof(hrrtc_Path) == 28712, "size of Path");
_Static_assert(_Alignof(hrrtc_Path) == 8, "alignment of Path");
_Static_assert(offsetof(hrrtc_Path, header) == 0, "offset of Path.header");
_Static_assert(offsetof(hrrtc_Path, len) == 24, "offset of Path.len");
_Static_assert(offsetof(hrrtc_Path, length) == 32, "offset of Path.length");
_Static_assert(offsetof(hrrtc_Path, waypoints) == 40, "offset of Path.waypoints");
#define HRRTC_PATH_TYPE_NAME "hrrtc::Path.v1"

/* iceoryx2 type name "hrrtc::RoadmapTree.v1" */
typedef struct hrrtc_RoadmapTree {
    uint32_t id;
    hrrtc_TreeKind kind;
    uint32_t len;
    uint32_t reserved;
} hrrtc_RoadmapTree;
_Static_assert(sizeof(hrrtc_RoadmapTree) == 16, "size of RoadmapTree");
_Static_assert(_Alignof(hrrtc_RoadmapTree) == 4, "alignment of RoadmapTree");
_Static_assert(offsetof(hrrtc_RoadmapTree, id) == 0, "offset of RoadmapTree.id");
_Static_assert(offsetof(hrrtc_RoadmapTree, kind) == 4, "offset of RoadmapTree.kind");
_Static_assert(offsetof(hrrtc_RoadmapTree, len) == 8, "offset of RoadmapTree.len");
_Static_assert(offsetof(hrrtc_RoadmapTree, reserved) == 12, "offset of RoadmapTree.reserved");
#define HRRTC_ROADMAP_TREE_TYPE_NAME "hrrtc::RoadmapTree.v1"

/* iceoryx2 type name "hrrtc::RoadmapNode.v1" */
typedef struct hrrtc_RoadmapNode {
    hrrtc_Pose pose;
    double distance_to_goal;
    uint32_t tree_id;
    uint32_t index;
    uint32_t parent;
    uint32_t extension_attempts;
    uint32_t collisions;
    uint32_t reserved;
} hrrtc_RoadmapNode;
_Static_assert(sizeof(hrrtc_RoadmapNode) == 88, "size of RoadmapNode");
_Static_assert(_Alignof(hrrtc_RoadmapNode) == 8, "alignment of RoadmapNode");
_Static_assert(offsetof(hrrtc_RoadmapNode, pose) == 0, "offset of RoadmapNode.pose");
_Static_assert(offsetof(hrrtc_RoadmapNode, distance_to_goal) == 56, "offset of RoadmapNode.distance_to_goal");
_Static_assert(offsetof(hrrtc_RoadmapNode, tree_id) == 64, "offset of RoadmapNode.tree_id");
_Static_assert(offsetof(hrrtc_RoadmapNode, index) == 68, "offset of RoadmapNode.index");
_Static_assert(offsetof(hrrtc_RoadmapNode, parent) == 72, "offset of RoadmapNode.parent");
_Static_assert(offsetof(hrrtc_RoadmapNode, extension_attempts) == 76, "offset of RoadmapNode.extension_attempts");
_Static_assert(offsetof(hrrtc_RoadmapNode, collisions) == 80, "offset of RoadmapNode.collisions");
_Static_assert(offsetof(hrrtc_RoadmapNode, reserved) == 84, "offset of RoadmapNode.reserved");
#define HRRTC_ROADMAP_NODE_TYPE_NAME "hrrtc::RoadmapNode.v1"

/* iceoryx2 type name "hrrtc::Roadmap.v1" */
typedef struct hrrtc_Roadmap {
    hrrtc_Header header;
    uint64_t iterations;
    uint64_t total_nodes;
    uint32_t trees_len;
    uint32_t trees_total;
    uint32_t nodes_len;
    uint32_t new_nodes;
    uint32_t solved;
    uint32_t reserved;
    hrrtc_RoadmapTree trees[64];
    hrrtc_RoadmapNode nodes[1024];
} hrrtc_Roadmap;
_Static_assert(sizeof(hrrtc_Roadmap) == 91200, "size of Roadmap");
_Static_assert(_Alignof(hrrtc_Roadmap) == 8, "alignment of Roadmap");
_Static_assert(offsetof(hrrtc_Roadmap, header) == 0, "offset of Roadmap.header");
_Static_assert(offsetof(hrrtc_Roadmap, iterations) == 24, "offset of Roadmap.iterations");
_Static_assert(offsetof(hrrtc_Roadmap, total_nodes) == 32, "offset of Roadmap.total_nodes");
_Static_assert(offsetof(hrrtc_Roadmap, trees_len) == 40, "offset of Roadmap.trees_len");
_Static_assert(offsetof(hrrtc_Roadmap, trees_total) == 44, "offset of Roadmap.trees_total");
_Static_assert(offsetof(hrrtc_Roadmap, nodes_len) == 48, "offset of Roadmap.nodes_len");
_Static_assert(offsetof(hrrtc_Roadmap, new_nodes) == 52, "offset of Roadmap.new_nodes");
_Static_assert(offsetof(hrrtc_Roadmap, solved) == 56, "offset of Roadmap.solved");
_Static_assert(offsetof(hrrtc_Roadmap, reserved) == 60, "offset of Roadmap.reserved");
_Static_assert(offsetof(hrrtc_Roadmap, trees) == 64, "offset of Roadmap.trees");
_Static_assert(offsetof(hrrtc_Roadmap, nodes) == 1088, "offset of Roadmap.nodes");
#define HRRTC_ROADMAP_TYPE_NAME "hrrtc::Roadmap.v1"

/* iceoryx2 type name "hrrtc::DriverState.v1" */
typedef struct hrrtc_DriverState {
    hrrtc_Header header;
    hrrtc_Pose pose;
    hrrtc_Twist twist;
    uint32_t buttons;
    hrrtc_DriverStatus status;
    uint8_t name[32];
    double max_force_n;
    double max_torque_nm;
    double max_stiffness_n_per_m;
    double max_rot_stiffness_nm_per_rad;
    double max_damping_n_s_per_m;
    double workspace_radius_m;
    uint32_t button_count;
    uint32_t orientation_input;
} hrrtc_DriverState;
_Static_assert(sizeof(hrrtc_DriverState) == 224, "size of DriverState");
_Static_assert(_Alignof(hrrtc_DriverState) == 8, "alignment of DriverState");
_Static_assert(offsetof(hrrtc_DriverState, header) == 0, "offset of DriverState.header");
_Static_assert(offsetof(hrrtc_DriverState, pose) == 24, "offset of DriverState.pose");
_Static_assert(offsetof(hrrtc_DriverState, twist) == 80, "offset of DriverState.twist");
_Static_assert(offsetof(hrrtc_DriverState, buttons) == 128, "offset of DriverState.buttons");
_Static_assert(offsetof(hrrtc_DriverState, status) == 132, "offset of DriverState.status");
_Static_assert(offsetof(hrrtc_DriverState, name) == 136, "offset of DriverState.name");
_Static_assert(offsetof(hrrtc_DriverState, max_force_n) == 168, "offset of DriverState.max_force_n");
_Static_assert(offsetof(hrrtc_DriverState, max_torque_nm) == 176, "offset of DriverState.max_torque_nm");
_Static_assert(offsetof(hrrtc_DriverState, max_stiffness_n_per_m) == 184, "offset of DriverState.max_stiffness_n_per_m");
_Static_assert(offsetof(hrrtc_DriverState, max_rot_stiffness_nm_per_rad) == 192, "offset of DriverState.max_rot_stiffness_nm_per_rad");
_Static_assert(offsetof(hrrtc_DriverState, max_damping_n_s_per_m) == 200, "offset of DriverState.max_damping_n_s_per_m");
_Static_assert(offsetof(hrrtc_DriverState, workspace_radius_m) == 208, "offset of DriverState.workspace_radius_m");
_Static_assert(offsetof(hrrtc_DriverState, button_count) == 216, "offset of DriverState.button_count");
_Static_assert(offsetof(hrrtc_DriverState, orientation_input) == 220, "offset of DriverState.orientation_input");
#define HRRTC_DRIVER_STATE_TYPE_NAME "hrrtc::DriverState.v1"

/* iceoryx2 type name "hrrtc::DriverCommand.v1" */
typedef struct hrrtc_DriverCommand {
    hrrtc_Header header;
    hrrtc_Wrench wrench;
    hrrtc_OutputCode output;
    uint32_t reserved;
} hrrtc_DriverCommand;
_Static_assert(sizeof(hrrtc_DriverCommand) == 80, "size of DriverCommand");
_Static_assert(_Alignof(hrrtc_DriverCommand) == 8, "alignment of DriverCommand");
_Static_assert(offsetof(hrrtc_DriverCommand, header) == 0, "offset of DriverCommand.header");
_Static_assert(offsetof(hrrtc_DriverCommand, wrench) == 24, "offset of DriverCommand.wrench");
_Static_assert(offsetof(hrrtc_DriverCommand, output) == 72, "offset of DriverCommand.output");
_Static_assert(offsetof(hrrtc_DriverCommand, reserved) == 76, "offset of DriverCommand.reserved");
#define HRRTC_DRIVER_COMMAND_TYPE_NAME "hrrtc::DriverCommand.v1"

#endif /* HRRTC_WIRE_H */
