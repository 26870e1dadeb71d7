/* The MAVLink C library's side of `cargo bench -p ferrolink-bench --bench mavlink`: the same
 * operations as the Rust sides, through the library's own API (generated at build time by
 * pymavlink's mavgen from the same common.xml as ours; nothing generated is kept in the tree).
 *
 * - encode: `mavlink_msg_*_pack` then `mavlink_msg_to_send_buffer`, as a sender does;
 * - decode: every byte through `mavlink_parse_char` (the library's only way to check a frame),
 *   then `mavlink_msg_*_decode`;
 * - stream: `mavlink_parse_char` over a buffer, each message decoded by its id.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "common/mavlink.h"

static void set_seq(uint8_t seq) { mavlink_get_channel_status(MAVLINK_COMM_0)->current_tx_seq = seq; }

size_t c_encode_heartbeat(uint8_t *out, uint8_t seq, uint8_t type, uint8_t autopilot,
                          uint8_t base_mode, uint32_t custom_mode, uint8_t system_status) {
    mavlink_message_t msg;
    set_seq(seq);
    mavlink_msg_heartbeat_pack(1, 1, &msg, type, autopilot, base_mode, custom_mode, system_status);
    return mavlink_msg_to_send_buffer(out, &msg);
}

size_t c_encode_attitude(uint8_t *out, uint8_t seq, uint32_t time_boot_ms, const float v[6]) {
    mavlink_message_t msg;
    set_seq(seq);
    mavlink_msg_attitude_pack(1, 1, &msg, time_boot_ms, v[0], v[1], v[2], v[3], v[4], v[5]);
    return mavlink_msg_to_send_buffer(out, &msg);
}

size_t c_encode_ftp(uint8_t *out, uint8_t seq, uint8_t target_network, uint8_t target_system,
                    uint8_t target_component, const uint8_t payload[251]) {
    mavlink_message_t msg;
    set_seq(seq);
    mavlink_msg_file_transfer_protocol_pack(1, 1, &msg, target_network, target_system,
                                            target_component, payload);
    return mavlink_msg_to_send_buffer(out, &msg);
}

/* Parses `len` bytes on channel 1; returns the message id of the last complete message, or -1. */
static int32_t parse(const uint8_t *bytes, size_t len, mavlink_message_t *msg) {
    mavlink_status_t status;
    int32_t id = -1;
    for (size_t i = 0; i < len; i++) {
        if (mavlink_parse_char(MAVLINK_COMM_1, bytes[i], msg, &status)) {
            id = (int32_t)msg->msgid;
        }
    }
    return id;
}

int32_t c_decode_heartbeat(const uint8_t *frame, size_t len, mavlink_heartbeat_t *out) {
    mavlink_message_t msg;
    int32_t id = parse(frame, len, &msg);
    if (id == MAVLINK_MSG_ID_HEARTBEAT) mavlink_msg_heartbeat_decode(&msg, out);
    return id;
}

int32_t c_decode_attitude(const uint8_t *frame, size_t len, mavlink_attitude_t *out) {
    mavlink_message_t msg;
    int32_t id = parse(frame, len, &msg);
    if (id == MAVLINK_MSG_ID_ATTITUDE) mavlink_msg_attitude_decode(&msg, out);
    return id;
}

int32_t c_decode_ftp(const uint8_t *frame, size_t len, mavlink_file_transfer_protocol_t *out) {
    mavlink_message_t msg;
    int32_t id = parse(frame, len, &msg);
    if (id == MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL) mavlink_msg_file_transfer_protocol_decode(&msg, out);
    return id;
}

/* The checksum alone over a frame body (after the magic byte), then CRC_EXTRA. */
uint16_t c_checksum(const uint8_t *body, size_t len, uint8_t crc_extra) {
    uint16_t crc = crc_calculate(body, (uint16_t)len);
    crc_accumulate(crc_extra, &crc);
    return crc;
}

/* Every message of the telemetry mix decoded into its struct; others are only counted. */
union decoded {
    mavlink_heartbeat_t heartbeat;
    mavlink_sys_status_t sys_status;
    mavlink_system_time_t system_time;
    mavlink_gps_raw_int_t gps_raw_int;
    mavlink_raw_imu_t raw_imu;
    mavlink_scaled_pressure_t scaled_pressure;
    mavlink_attitude_t attitude;
    mavlink_global_position_int_t global_position_int;
    mavlink_servo_output_raw_t servo_output_raw;
    mavlink_rc_channels_t rc_channels;
    mavlink_mission_current_t mission_current;
    mavlink_nav_controller_output_t nav_controller_output;
    mavlink_vfr_hud_t vfr_hud;
    mavlink_battery_status_t battery_status;
    mavlink_power_status_t power_status;
    mavlink_timesync_t timesync;
};

/* Parses and decodes a whole buffer; returns how many messages; `sink` gets each one. */
size_t c_stream(const uint8_t *bytes, size_t len, void (*sink)(const void *)) {
    mavlink_message_t msg;
    mavlink_status_t status;
    union decoded d;
    size_t n = 0;
    for (size_t i = 0; i < len; i++) {
        if (!mavlink_parse_char(MAVLINK_COMM_2, bytes[i], &msg, &status)) continue;
        switch (msg.msgid) {
        case MAVLINK_MSG_ID_HEARTBEAT: mavlink_msg_heartbeat_decode(&msg, &d.heartbeat); break;
        case MAVLINK_MSG_ID_SYS_STATUS: mavlink_msg_sys_status_decode(&msg, &d.sys_status); break;
        case MAVLINK_MSG_ID_SYSTEM_TIME: mavlink_msg_system_time_decode(&msg, &d.system_time); break;
        case MAVLINK_MSG_ID_GPS_RAW_INT: mavlink_msg_gps_raw_int_decode(&msg, &d.gps_raw_int); break;
        case MAVLINK_MSG_ID_RAW_IMU: mavlink_msg_raw_imu_decode(&msg, &d.raw_imu); break;
        case MAVLINK_MSG_ID_SCALED_PRESSURE: mavlink_msg_scaled_pressure_decode(&msg, &d.scaled_pressure); break;
        case MAVLINK_MSG_ID_ATTITUDE: mavlink_msg_attitude_decode(&msg, &d.attitude); break;
        case MAVLINK_MSG_ID_GLOBAL_POSITION_INT: mavlink_msg_global_position_int_decode(&msg, &d.global_position_int); break;
        case MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: mavlink_msg_servo_output_raw_decode(&msg, &d.servo_output_raw); break;
        case MAVLINK_MSG_ID_RC_CHANNELS: mavlink_msg_rc_channels_decode(&msg, &d.rc_channels); break;
        case MAVLINK_MSG_ID_MISSION_CURRENT: mavlink_msg_mission_current_decode(&msg, &d.mission_current); break;
        case MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT: mavlink_msg_nav_controller_output_decode(&msg, &d.nav_controller_output); break;
        case MAVLINK_MSG_ID_VFR_HUD: mavlink_msg_vfr_hud_decode(&msg, &d.vfr_hud); break;
        case MAVLINK_MSG_ID_BATTERY_STATUS: mavlink_msg_battery_status_decode(&msg, &d.battery_status); break;
        case MAVLINK_MSG_ID_POWER_STATUS: mavlink_msg_power_status_decode(&msg, &d.power_status); break;
        case MAVLINK_MSG_ID_TIMESYNC: mavlink_msg_timesync_decode(&msg, &d.timesync); break;
        default: break;
        }
        sink(&d);
        n++;
    }
    return n;
}
