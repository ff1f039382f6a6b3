"""mavros sys_time: TIMESYNC with the FCU, its clock offset, and ~time_reference.

As mavros's sys_time plugin does it (timesync mode MAVLINK, the default):
- every 1/conn/timesync_rate s the bridge asks: TIMESYNC(tc1=0, ts1=ROS time in ns);
- it answers the FCU's own requests (PX4 sends 10 a second): TIMESYNC(tc1=ROS time, ts1=theirs);
  unlike mavros, whose timer is not in step with anything, the bridge's own request, when due
  within one period, goes in the datagram of that answer (and then not on its timer): the
  rate is the same and every request still carries its own send time, but the FCU reads one
  datagram instead of two (10 fewer wake-ups a second for a simulated PX4);
- each answer to one of ours is an observation of the offset (ROS time minus FCU time,
  assuming the round trip is symmetric). Samples with a round trip over time/max_rtt_sample
  are not used; a double exponential filter (alpha for the offset, beta for its drift)
  smooths the rest, its gains moving from *_initial to *_final over time/convergence_window
  samples. Once converged, a run of samples far from the estimate (a clock jump on the FCU)
  resets it.
- FCU-stamped topics are stamped FCU time + offset once the filter has converged (as mavros
  hands the offset on, from the sample after the window's last; a reset keeps the last offset
  until the next accepted sample); before that (and with mode NONE) they are stamped with ROS
  time now, as mavros's synchronise_stamp(). PASSTHROUGH stamps with the FCU's time as it is.
- SYSTEM_TIME with a plausible Unix time is published on ~time_reference
  (sensor_msgs/TimeReference, source time/time_ref_source).
- SYSTEM_TIME goes to the FCU every 1/conn/system_time_rate s (px4_config.yaml: 1.0): time_unix_usec
  the ROS time, time_boot_ms 0, as mavros's sys_time timer sends it (reference/px4-sitl-measured.md,
  "Recorded conversations": real mavros sends SYSTEM_TIME at 1.0 a second, time_boot_ms 0).
"""

import logging
import math

from mavros_msgs.msg import TimesyncStatus
from sensor_msgs.msg import TimeReference

from offboard_py.bridge import diagnostics

log = logging.getLogger(__name__)

MODES = ('MAVLINK', 'NONE', 'PASSTHROUGH')
# mavros: a Unix time before this (2009-02-13) is not a real clock
UNIX_VALID_AFTER_US = 1234567890 * 1000000


class TimesyncFilter:
    """mavros's offset filter, without ROS: feed observe(), read offset_ns."""

    def __init__(self, alpha_initial=0.05, beta_initial=0.05, alpha_final=0.003, beta_final=0.003,
                 convergence_window=500, max_rtt_ms=10.0, max_deviation_ms=100.0, max_high_rtt=5,
                 max_high_deviation=5):
        self.alpha_initial, self.beta_initial = alpha_initial, beta_initial
        self.alpha_final, self.beta_final = alpha_final, beta_final
        self.convergence_window = convergence_window
        self.max_rtt_ns, self.max_deviation_ns = max_rtt_ms * 1e6, max_deviation_ms * 1e6
        self.max_high_rtt, self.max_high_deviation = max_high_rtt, max_high_deviation
        self.applied_ns = 0  # the offset stamps use (mavros's UAS time offset): set by accepted samples only
        self.jumps = 0  # resets after a run of samples far from the estimate
        self.reset()

    def reset(self):
        self.sequence = 0
        self.estimate_ns = 0.0
        self.skew_ns = 0.0
        self.high_rtt = self.high_deviation = 0

    @property
    def converged(self):
        return self.sequence >= self.convergence_window

    @property
    def offset_ns(self):
        """The offset to apply (ROS time = FCU time + offset), as mavros hands it to its UAS: each accepted
        sample sets it, to the estimate once the filter had converged before that sample (so from the
        (window + 1)th sample on), else to 0; a reset leaves it as it was until the next accepted sample."""
        return self.applied_ns

    def observe(self, offset_ns, rtt_ns):
        """One TIMESYNC round trip. Returns a warning to log, or None."""
        if not 0 <= rtt_ns < self.max_rtt_ns:  # negative: not an answer to one of ours
            self.high_rtt += 1
            if self.high_rtt > self.max_high_rtt:
                self.high_rtt = 0
                return 'TM : RTT too high for timesync: %.2f ms.' % (rtt_ns / 1e6)
            return None
        if self.converged and abs(self.estimate_ns - offset_ns) > self.max_deviation_ns:
            self.high_deviation += 1
            if self.high_deviation > self.max_high_deviation:
                self.reset()
                self.jumps += 1
                return 'TM : Time jump detected. Resetting time synchroniser.'
            return None
        if self.converged:
            alpha, beta = self.alpha_final, self.beta_final
        else:  # gain scheduling: a sigmoid from the initial to the final gains
            progress = self.sequence / self.convergence_window
            p = 1.0 - math.exp(0.5 * (1.0 - 1.0 / (1.0 - progress)))
            alpha = p * self.alpha_final + (1.0 - p) * self.alpha_initial
            beta = p * self.beta_final + (1.0 - p) * self.beta_initial
        if self.sequence == 0:
            self.estimate_ns = float(offset_ns)
        else:
            previous = self.estimate_ns
            self.estimate_ns = alpha * offset_ns + (1.0 - alpha) * (self.estimate_ns + self.skew_ns)
            self.skew_ns = beta * (self.estimate_ns - previous) + (1.0 - beta) * self.skew_ns
        self.applied_ns = int(self.estimate_ns) if self.converged else 0  # before the count moves, as mavros
        self.sequence += 1
        self.high_deviation = self.high_rtt = 0
        return None


class SysTime:
    def __init__(self, bridge):
        self.bridge = bridge
        cfg = bridge.cfg
        self.mode = cfg['time/timesync_mode']
        self.source = cfg['time/time_ref_source']
        self.filter = TimesyncFilter(**cfg['time/filter'])
        bridge.provide('clock_offset', self)  # what Bridge.fcu_stamp_* read
        self.time_ref_pub = bridge.publisher('~time_reference', TimeReference)
        self.status_pub = bridge.publisher('~timesync_status', TimesyncStatus)
        bridge.on('SYSTEM_TIME', self._on_system_time)
        bridge.on('TIMESYNC', self._on_timesync)
        # mavros's TimeSyncStatus: every answer to one of our requests, kept or not
        self.events = diagnostics.EventWindow(bridge.monotonic_s, min_hz=0.01, max_hz=10.0)
        self.last_rtt_ns = self.rtt_sum_ns = self.last_remote_ns = 0
        rate = cfg['conn/timesync_rate']
        self.request_task = None
        if self.mode == 'MAVLINK' and rate > 0.0:  # as mavros: the status only while it syncs
            self.request_task = bridge.every(1.0 / rate, self._request)
            bridge.diagnostic('Time Sync', self._status)
        system_time_rate = cfg['conn/system_time_rate']
        if system_time_rate > 0.0:
            bridge.every(1.0 / system_time_rate, self._send_system_time)

    # -- the offset -----------------------------------------------------------------------

    def stamp_ns(self, fcu_ns):
        """ROS time (ns) of an FCU time (ns since its boot), or None for "stamp with now"."""
        if self.mode == 'PASSTHROUGH':
            return fcu_ns
        offset = self.filter.offset_ns if self.mode == 'MAVLINK' else 0
        return fcu_ns + offset if offset > 0 else None

    # -- TIMESYNC -------------------------------------------------------------------------

    def _request(self, _now_s):
        if self.bridge.connected:
            self.bridge.send(self.bridge.mav.timesync_encode(0, self.bridge.now_ns()))

    def _send_system_time(self, _now_s):
        if self.bridge.connected:
            self.bridge.send(self.bridge.mav.system_time_encode(self.bridge.now_ns() // 1000, 0))

    def _on_timesync(self, msg):
        now_ns = self.bridge.now_ns()
        if msg.tc1 == 0:  # the FCU asks: answer with our clock, whatever our own mode
            answer = self.bridge.mav.timesync_encode(now_ns, msg.ts1)
            if (self.request_task is not None and self.bridge.connected
                    and self.bridge.take_early(self.request_task, self.bridge.monotonic_s())):
                self.bridge.send(answer)
                self.bridge.send(self.bridge.mav.timesync_encode(0, now_ns))  # and ask, in step with the answer
            else:
                self.bridge.send(answer)
        elif msg.tc1 > 0 and self.mode == 'MAVLINK':
            offset = (msg.ts1 + now_ns - 2 * msg.tc1) // 2
            rtt = now_ns - msg.ts1
            jumps = self.filter.jumps
            warning = self.filter.observe(offset, rtt)
            if warning:
                log.warning('%s', warning)
            if self.filter.jumps != jumps:  # mavros clears the status with the filter
                self.events.clear()
                self.rtt_sum_ns = 0
            self.events.tick()
            self.last_rtt_ns, self.last_remote_ns = rtt, msg.tc1
            self.rtt_sum_ns += rtt
            if self.status_pub.get_num_connections():
                status = TimesyncStatus(remote_timestamp_ns=msg.tc1, observed_offset_ns=offset,
                                        estimated_offset_ns=int(self.filter.estimate_ns),
                                        round_trip_time_ms=rtt / 1e6)
                status.header.stamp = self.bridge.now()
                self.status_pub.publish(status)

    def _status(self):
        """mavros's TimeSyncStatus: the answers over the last ten periods (0.01-10 Hz), the round
        trips (the last, the mean of all since the start or the last reset), the estimate."""
        level, message, frequency = self.events.run()
        count = self.events.count
        return level, message, [('Timesyncs since startup', count), ('Frequency (Hz)', '%f' % frequency),
                                ('Last RTT (ms)', '%0.6f' % (self.last_rtt_ns / 1e6)),
                                ('Mean RTT (ms)', '%0.6f' % (self.rtt_sum_ns / count / 1e6 if count else 0.0)),
                                ('Last remote time (s)', '%0.9f' % (self.last_remote_ns / 1e9)),
                                ('Estimated time offset (s)', '%0.9f' % (int(self.filter.estimate_ns) / 1e9))]

    def _on_system_time(self, msg):
        if msg.time_unix_usec <= UNIX_VALID_AFTER_US or not self.time_ref_pub.get_num_connections():
            return
        ref = TimeReference()
        ref.header.stamp = self.bridge.now()
        ref.time_ref = self.bridge.time_from_ns(msg.time_unix_usec * 1000)
        ref.source = self.source
        self.time_ref_pub.publish(ref)
