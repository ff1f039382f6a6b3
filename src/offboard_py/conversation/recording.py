"""Writing a recording of the FCU link as a pcap that reading.read (and Wireshark) reads.

Each datagram is written as the references were captured (reference/conversations/README.md):
Ethernet/IPv4/UDP on loopback, the FCU's side from port 14580 to 14540 and the ROS side's the other
way, whatever ports the recorded link really used, so that a recording of any SITL instance reads
like the references. Stamps are the caller's: the relay gives simulated seconds
(offboard_py.simtime), so a flight at 5x compares second for second with one recorded in real time.
Standard library only.
"""

import struct

from offboard_py.conversation.reading import FCU_PORT

ROS_PORT = 14540   # the ROS side's port on the references' link (mavros's fcu_url udp://:14540@...)
LOOPBACK = bytes((127, 0, 0, 1))
ETHERNET_HEADER = bytes(12) + struct.pack('!H', 0x0800)


def _ipv4_checksum(header):
    total = sum(struct.unpack('!10H', header))
    total = (total & 0xffff) + (total >> 16)
    total = (total & 0xffff) + (total >> 16)
    return ~total & 0xffff


class PcapWriter:
    """write(stamp_s, from_fcu, payload) appends one datagram; flush() makes it readable to others."""

    def __init__(self, path):
        self.path = path
        self.file = open(path, 'wb')
        # libpcap: magic, version 2.4, zone 0, sigfigs 0, snaplen, link type Ethernet
        self.file.write(struct.pack('<IHHiIII', 0xa1b2c3d4, 2, 4, 0, 0, 262144, 1))
        self.ident = 0
        self.count = 0

    def write(self, stamp_s, from_fcu, payload):
        sport, dport = (FCU_PORT, ROS_PORT) if from_fcu else (ROS_PORT, FCU_PORT)
        udp = struct.pack('!HHHH', sport, dport, 8 + len(payload), 0) + payload
        self.ident = (self.ident + 1) & 0xffff
        ip = struct.pack('!BBHHHBBH4s4s', 0x45, 0, 20 + len(udp), self.ident, 0x4000, 64, 17, 0, LOOPBACK, LOOPBACK)
        ip = ip[:10] + struct.pack('!H', _ipv4_checksum(ip)) + ip[12:]
        frame = ETHERNET_HEADER + ip + udp
        seconds = int(stamp_s)
        micros = int(round((stamp_s - seconds) * 1e6))
        if micros >= 1000000:
            seconds, micros = seconds + 1, micros - 1000000
        self.file.write(struct.pack('<IIII', seconds, micros, len(frame), len(frame)) + frame)
        self.count += 1

    def flush(self):
        self.file.flush()

    def close(self):
        if not self.file.closed:
            self.file.close()
