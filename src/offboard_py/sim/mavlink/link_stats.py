"""The link statistics of a MAVLink link of the simulated PX4 (LINK_NODE_STATUS's counters), as PX4's
mavlink module keeps them (mavlink_main.cpp's telemetry_status rates; mavlink_receiver.cpp's
update_rx_stats for the messages lost)."""


class LinkCounters:
    """A link's byte rates as PX4's mavlink module keeps them (telemetry_status tx/rx_rate_avg): the
    bytes of a window of (about) a second over its length, a new window each time. PX4's main loop
    closes a window every second whoever reads it; here the window closes when the rates are read
    at least WINDOW_S after it opened (a 1 Hz LINK_NODE_STATUS reads them once a window).

    `lost` counts what the senders' sequence numbers say was lost, per (system, component), as PX4's
    MavlinkReceiver::update_rx_stats does (`on_frame` sees every valid frame the link receives):
    a sequence number behind the expected one counts 255 - expected + seq, so a sender that always
    sends seq 0 costs 254 a message (reference/px4-sitl-measured.md, "Turn 3 recordings", section 4)."""

    WINDOW_S = 0.999  # a second, less the float error of a 1 Hz stream's slot times

    def __init__(self, stats, now_s):
        self.stats = stats  # the link's Counter (MavlinkLink.stats)
        self.tx_rate = self.rx_rate = 0.0
        self._since_s, self._tx, self._rx = now_s, 0, 0
        self.lost = 0
        self._last_seq = {}  # (system, component) -> the last sequence number

    def on_frame(self, frame):
        """A valid MAVLink 1 or 2 frame the link received (MavlinkLink.on_frames)."""
        if frame[0] == 0xFD:
            seq, source = frame[4], (frame[5], frame[6])
        else:
            seq, source = frame[2], (frame[3], frame[4])
        last = self._last_seq.get(source)
        if last is not None:
            expected = (last + 1) & 0xFF
            if seq > expected:
                self.lost += seq - expected
            elif seq < expected:
                self.lost += 255 - expected + seq
        self._last_seq[source] = seq

    def update(self, now_s):
        """The link's counters, the rates brought up to date first."""
        stats, dt = self.stats, now_s - self._since_s
        if dt >= self.WINDOW_S:
            tx, rx = stats['bytes_sent'], stats['bytes_received']
            self.tx_rate, self.rx_rate = (tx - self._tx) / dt, (rx - self._rx) / dt
            self._since_s, self._tx, self._rx = now_s, tx, rx
        return stats
