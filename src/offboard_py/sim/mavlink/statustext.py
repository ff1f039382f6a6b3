"""The simulated PX4's STATUSTEXT: the texts queued for each link (PX4's mavlink_log queue) and the STATUSTEXT
stream that sends them (src/modules/mavlink/streams/STATUSTEXT.hpp), only on a link where a ground station
is heard (Mavlink::is_gcs_connected, telemetry_status)."""

import collections
import logging

from offboard_py.dialect import mavlink
from offboard_py.sim.data_link import GCS_HEARTBEAT_TIMEOUT_S
from offboard_py.sim.mavlink.streams import send_on

log = logging.getLogger('offboard_py.sim')

# PX4's STATUSTEXT stream (streams/STATUSTEXT.hpp) sends on a link only while a MAV_TYPE_GCS HEARTBEAT was
# heard on it within telemetry_status HEARTBEAT_TIMEOUT_US (2.5 s), one text each time it runs (20 Hz), from
# the mavlink_log queue (8 deep: older texts are overwritten), dropping texts older than 5 s
STATUSTEXT_INTERVAL_S = 0.05
STATUSTEXT_QUEUE = 8
STATUSTEXT_STALE_S = 5.0
# PX4's STATUSTEXT stream sends a text of its log queue (mavlink_log: char[127], so 126 characters) in
# chunks of STATUSTEXT.text's 50 bytes (streams/STATUSTEXT.hpp)
STATUSTEXT_MAX_CHARS = 126
STATUSTEXT_CHUNK_BYTES = 50


def statustext(mav, severity, text, text_id):
    """A text as PX4's STATUSTEXT stream sends it: the first STATUSTEXT_MAX_CHARS of it (PX4's log
    queue's char[127]) in chunks of 50 bytes, chunk_seq 0, 1, ..., each with the text's `text_id`;
    nothing for an empty text, as PX4."""
    data = text.encode('ascii', 'replace')[:STATUSTEXT_MAX_CHARS]
    chunk = STATUSTEXT_CHUNK_BYTES
    return [mav.statustext_encode(severity, data[i:i + chunk], text_id, seq)
            for seq, i in enumerate(range(0, len(data), chunk))]


class StatustextQueue:
    """Each link's text queue, its GCS HEARTBEAT and its STATUSTEXT stream; `mav` encodes the messages."""

    def __init__(self, links, mav):
        self.mav = mav
        self.gcs_heard = {link: None for link in links}  # boot time of the link's last GCS HEARTBEAT
        self.texts = {link: collections.deque(maxlen=STATUSTEXT_QUEUE) for link in links}  # (t, sev, text)
        self.text_sent = {link: None for link in links}  # boot time of the link's last STATUSTEXT
        self.text_ids = {link: 0 for link in links}  # the link's next STATUSTEXT.id: PX4 counts per stream

    def add(self, severity, text, now):
        """Into every link's queue: each sends it while a ground station is heard on it (send)."""
        log.info('%s', text)
        for queue in self.texts.values():
            queue.append((now, severity, text))

    def on_heartbeat(self, link, msg, now):
        """A ground station's HEARTBEAT (MAV_TYPE_GCS, any system) lets STATUSTEXT out on its link, as
        PX4's is_gcs_connected(); mavros's MAV_TYPE_ONBOARD_CONTROLLER does not."""
        if msg.type == mavlink.MAV_TYPE_GCS:
            self.gcs_heard[link] = now

    def gcs_connected(self, link, now):
        heard = self.gcs_heard[link]
        return heard is not None and now - heard <= GCS_HEARTBEAT_TIMEOUT_S

    def send(self, now, out=None):
        """A link's next fresh text (all its chunks), at most one every STATUSTEXT_INTERVAL_S, while a GCS is
        heard on it; what waits while none is stays queued (STATUSTEXT_QUEUE) and is dropped once
        STATUSTEXT_STALE_S old."""
        for link, queue in self.texts.items():
            if not queue or not self.gcs_connected(link, now):
                continue
            last = self.text_sent[link]
            if last is not None and now - last < STATUSTEXT_INTERVAL_S:
                continue
            while queue:
                said, severity, text = queue.popleft()
                if now - said < STATUSTEXT_STALE_S:
                    msgs = statustext(self.mav, severity, text, self.text_ids[link])
                    self.text_ids[link] = (self.text_ids[link] + 1) % 65536  # PX4's uint16_t _id
                    send_on(link, msgs, out)
                    self.text_sent[link] = now
                    break
