#!/usr/bin/env python3
"""Writes the binary and multi-file seed corpora of tests/fuzz/corpus (run from any folder).

The text seeds of single files are copies of fixtures (sensor.yaml, configs); the ones built here
are binary formats (PNG, MAVLink, map, vocabulary, D455 replies) and the "--"-separated bundles
the multi-file harnesses split (fuzz_file.hpp). Output is deterministic.
"""
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "corpus")


def put(target, name, data):
    folder = os.path.join(CORPUS, target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)


def png(w, h, color_type=0, bit_depth=8, value=None):
    channels = {0: 1, 2: 3, 4: 2, 6: 4}[color_type]
    raw = b"".join(b"\x00" + bytes(((x * 7 + y * 13) & 0xFF) if value is None else value
                                    for x in range(w * channels)) for y in range(h))

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    ihdr = struct.pack(">IIBBBBB", w, h, bit_depth, color_type, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def crc_x25(data, crc=0xFFFF):
    for byte in data:
        tmp = (byte ^ (crc & 0xFF)) & 0xFF
        tmp = (tmp ^ (tmp << 4)) & 0xFF
        crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    return crc


def mavlink_v2(msg_id, crc_extra, payload, seq=0):
    header = struct.pack("<BBBBBBB", len(payload), 0, 0, seq, 1, 1, msg_id & 0xFF) + struct.pack("<H", msg_id >> 8)
    crc = crc_x25(bytes([crc_extra]), crc_x25(header + payload))
    return b"\xFD" + header + payload + struct.pack("<H", crc)


def euroc_seeds():
    cam = "#timestamp [ns],filename\r\n1000,1000.png\n"
    imu_header = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y,w_RS_S_z,a_RS_S_x,a_RS_S_y,a_RS_S_z\n"
    imu = imu_header + "".join(f"{t},0.001,-0.002,0.07,9.08,0.13,-3.69\n" for t in range(900, 1200, 50))
    put("euroc_csv", "pair.txt", cam + "--\n" + cam + "--\n" + imu)
    put("euroc_csv", "unpaired.txt", "\ufeff1000,1000.png\n2000,2000.png\n--\n1500,1500.png\n--\n" + imu)


def groundtruth_seeds():
    header = ("#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
              "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x, b_w_RS_S_y, b_w_RS_S_z, "
              "b_a_RS_S_x, b_a_RS_S_y, b_a_RS_S_z\n")
    rows = "".join(f"{1403715273262142976 + i * 5000000},0.878,{2.14 + i * 0.001},0.947,0.06,-0.828,-0.058,-0.553,"
                   "0.009,-0.012,0.004,-0.0022,0.0208,0.0757,-0.0127,0.1178,0.0721\n" for i in range(3))
    put("groundtruth", "euroc.csv", header + rows)
    put("trajectory", "euroc.csv", header + rows)
    put("trajectory", "tum.txt", "# t x y z qx qy qz qw\n1.0 0 0 0 0 0 0 1\n1.1 0.1 0 0 0 0 0.0499792 0.99875\n"
                                 "1.2 0.2 0.01 0 0 0 0.0998334 0.995004\n")
    gt = os.path.join(HERE, "../../../shared/data/euroc/groundtruth/V101_GT.txt")
    if os.path.exists(gt):
        with open(gt) as f:
            put("trajectory", "shared_gt.txt", "".join(f.readlines()[:6]))


def config_seeds():
    fixtures = os.path.join(HERE, "fixtures", "euroc")
    for name in ("cam0", "imu0"):
        with open(os.path.join(fixtures, name + ".yaml")) as f:
            text = f.read()
        put("sensor_yaml", name + ".yaml", text)
        put("trajectory", name + "_sensor.yaml", text) if name == "cam0" else None
    camodocal = ("%YAML:1.0\n---\nmodel_type: PINHOLE\ncamera_name: camera\nimage_width: 752\nimage_height: 480\n"
                 "distortion_parameters:\n   k1: -2.917e-01\n   k2: 8.228e-02\n   p1: 5.333e-05\n   p2: -1.578e-04\n"
                 "projection_parameters:\n   fx: 4.616e+02\n   fy: 4.603e+02\n   cx: 3.630e+02\n   cy: 2.481e+02\n")
    body = lambda x: ("!!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n   data: [0.0148655429818, -0.999880929698, "
                      "0.00414029679422, -0.0216401454975, 0.999557249008, 0.0149672133247, 0.025715529948, "
                      f"{x}, -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949, 0, 0, 0, 1]\n")
    vins = ("%YAML:1.0\nimu: 1\nnum_of_cam: 2\ncam0_calib: \"cam0.yaml\"\ncam1_calib: \"cam1.yaml\"\n"
            "image_width: 752\nimage_height: 480\nestimate_extrinsic: 1\n"
            "body_T_cam0: " + body(-0.0647) + "body_T_cam1: " + body(0.0454) +
            "max_cnt: 150\nmin_dist: 30\nF_threshold: 1.0\nmax_solver_time: 0.04\nmax_num_iterations: 8\n"
            "keyframe_parallax: 10.0\nacc_n: 0.1\ngyr_n: 0.01\nacc_w: 0.001\ngyr_w: 0.0001\ng_norm: 9.81007\n"
            "estimate_td: 0\ntd: 0.0\n")
    put("app_config", "vins_fusion.txt", vins + "--\n" + camodocal + "--\n" + camodocal)
    with open(os.path.join(HERE, "../../board/d455/d455.yaml")) as f:
        put("app_config", "d455.yaml", f.read())
    chain = ("cam0:\n  T_cam_imu:\n  - [0.9998, 0.0, 0.0175, 0.0173]\n  - [0.0, 1.0, 0.0, -0.0085]\n"
             "  - [-0.0175, 0.0, 0.9998, -0.0187]\n  - [0.0, 0.0, 0.0, 1.0]\n  cam_overlaps: [1]\n"
             "  camera_model: pinhole\n  distortion_coeffs: [0.001, -0.002, 0.0001, 0.0002]\n"
             "  distortion_model: radtan\n  intrinsics: [320.17, 320.03, 314.07, 180.37]\n  resolution: [640, 360]\n"
             "  timeshift_cam_imu: 0.0048\n"
             "cam1:\n  T_cam_imu:\n  - [0.9998, 0.0, 0.0175, -0.0767]\n  - [0.0, 1.0, 0.0, -0.0085]\n"
             "  - [-0.0175, 0.0, 0.9998, -0.0187]\n  - [0.0, 0.0, 0.0, 1.0]\n  camera_model: pinhole\n"
             "  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]\n  distortion_model: equidistant\n"
             "  intrinsics: [320.5, 320.4, 313.9, 180.1]\n  resolution: [640, 360]\n  timeshift_cam_imu: 0.0049\n")
    imu = ("imu0:\n  T_i_b:\n  - [1.0, 0.0, 0.0, 0.0]\n  - [0.0, 1.0, 0.0, 0.0]\n  - [0.0, 0.0, 1.0, 0.0]\n"
           "  - [0.0, 0.0, 0.0, 1.0]\n  accelerometer_noise_density: 0.00208\n  accelerometer_random_walk: 0.000413\n"
           "  gyroscope_noise_density: 0.000206\n  gyroscope_random_walk: 1.11e-05\n  update_rate: 400.0\n")
    put("kalibr", "chain_and_imu.txt", chain + "--\n" + imu)
    put("kalibr", "chain_only.yaml", chain)


def device_seeds():
    put("png", "gray8.png", png(8, 6))
    put("png", "rgb.png", png(5, 4, color_type=2))
    put("png", "gray_alpha.png", png(4, 3, color_type=4))
    put("png", "gray16.png", png(3, 2, bit_depth=16))
    put("y8i", "4x2.bin", bytes([3, 1, 2]) + bytes(range(40)))
    put("y8i", "wide.bin", bytes([40, 3, 0]) + bytes((i * 5) & 0xFF for i in range(2 * 41 * 4)))
    uvc_header = struct.pack("<BB", 12, 0x0C) + struct.pack("<I", 123456) + struct.pack("<IH", 99, 7)
    put("uvc_metadata", "uvch.bin", struct.pack("<QH", 10**15, 3) + uvc_header)
    timing = struct.pack("<IIIIIIII", 0x80000001, 32, 0, 0x0B, 42, 1500, 0, 8000)
    depth = struct.pack("<II", 0x80000000, 57) + bytes(48) + b"\x01"
    body = struct.pack("<I", 123456) + struct.pack("<IH", 99, 7) + timing + depth
    put("uvc_metadata", "d4xx.bin", struct.pack("<QH", 10**15, 3) + struct.pack("<BB", 2 + len(body), 0x0C) + body)
    record = struct.pack("<hhhxxq", 100, -200, 300, 123456789)
    put("iio_scan", "accel.txt", b"0 le:s16/16>>0\n1 le:s16/16>>0\n2 le:s16/16>>0\n3 le:s64/64>>0\n--\n" + record * 3)
    put("iio_scan", "be_shift.txt", b"0 be:u12/16>>4\n1 le:s32/32X1>>0\n--\n" + bytes(range(16)))
    table = bytearray(576)
    struct.pack_into("<HHII", table, 0, 2, 25, 576 - 16, 0)
    struct.pack_into("<f", table, 160, 95.0)
    for i in range(16):
        struct.pack_into("<ffff", table, 256 + 16 * i, 430.0, 430.0, 424.0, 240.0)
    struct.pack_into("<ffff", table, 256 + 16 * 3, 430.0, 430.0, 424.0, 240.0)
    struct.pack_into("<I", table, 12, zlib.crc32(bytes(table[16:])))
    put("factory_calibration", "table.bin", bytes(table))
    reply = bytearray(1024)
    struct.pack_into("<I", reply, 0, 0x15)
    reply[4:4 + 576] = table
    struct.pack_into("<I", reply, 1020, 4 + 576)
    put("factory_calibration", "reply.bin", bytes(reply))


def link_seeds():
    timesync = struct.pack("<qq", 0, 1234567890123)
    heartbeat = struct.pack("<IBBBBB", 0, 2, 12, 0, 4, 3)
    put("mavlink", "timesync.bin", mavlink_v2(111, 34, timesync))
    put("mavlink", "stream.bin", b"\x00\xFE" + mavlink_v2(0, 50, heartbeat, 1) + mavlink_v2(111, 34, timesync, 2) +
        mavlink_v2(331, 91, bytes(20), 3))


def loop_seeds():
    k, levels = 2, 1
    n = 1 + k
    voc = b"UMSVOCAB" + struct.pack("<IIII", 1, k, levels, n) + bytes([1] * n)
    voc += b"".join(bytes([(i * 37 + j) & 0xFF for j in range(32)]) for i in range(n))
    voc += b"".join(struct.pack("<f", 0.0 if i == 0 else 0.7) for i in range(n))
    put("vocabulary", "k2l1.voc", voc + struct.pack("<I", zlib.crc32(voc)))
    # Map: header (checksum and calibration hash are set by the harness), one keyframe, one feature.
    m = b"UMSMAP01" + struct.pack("<IIIII", 1, 0, 0, 2, 1)
    for i in range(2):
        m += struct.pack("<IqI", i, 10**9 * (i + 1), 0) + struct.pack("<7d", i * 0.5, 0, 0, 0, 0, 0, 1)
        m += struct.pack("<H", 1) + bytes(range(32)) + struct.pack("<3f", 1, 2, 5) + struct.pack("<3f", 0.2, 0.4, 0.9)
    m += struct.pack("<II", 0, 1) + struct.pack("<7d", 0.5, 0, 0, 0, 0, 0, 1)
    put("loop_map", "two_keyframes.map", m + struct.pack("<I", zlib.crc32(m)))


if __name__ == "__main__":
    euroc_seeds()
    groundtruth_seeds()
    config_seeds()
    device_seeds()
    link_seeds()
    loop_seeds()
