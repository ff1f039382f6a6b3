"""The measurement side of the simulated PX4, for `./run bench` (bench/benchmark.py): nothing here is PX4's.

With `--setpoint-log DIR` the simulator's command line (sim.main) attaches `BenchLogs` to its vehicles: each
accepted setpoint's arrival through the autopilot's instrumentation seam (SimulatedPx4.setpoint_probes), each
stall of the loop through its `on_stall` (sim.loop.run_together), written to DIR/setpoints-N.txt and
DIR/stalls-N.txt at exit. Without the option nothing here runs.
"""

import logging
import os
import time


class _BenchLog:
    """Rows for the benchmark, kept in memory and written at exit (to `path`, or the one given then).
    Times are on ROS's clock: Unix time in real time, the simulated clock (ns) at any other speed."""

    row_format = ''

    def __init__(self, path=None, clock=None):
        self.path, self.rows = path, []
        self.simulated = None if clock is None or clock.real_time else clock

    def clock_ns(self, wall_ns):
        """Now on the log's clock, given the wall's now (Unix ns)."""
        return wall_ns if self.simulated is None else int(self.simulated.now() * 1e9)

    def write(self, path=None):
        with open(path or self.path, 'w') as out:
            out.write(''.join(self.row_format % row for row in self.rows))


class SetpointLog(_BenchLog):
    """For the benchmark: each accepted setpoint's arrival (ns), time_boot_ms, and when the simulator read
    it (ns), so the receive path only appends a row. The arrival is the kernel's receive time of its
    datagram (MavlinkLink.stamp_arrivals): the stream as it reached the FCU, which is what PX4's receive
    thread, blocked on the socket, sees of it. The read time is when this process got to it, later by
    however long a busy simulator took; the benchmark reports that lag on its own. Where the kernel gives
    no stamp, the arrival is the read time."""

    row_format = '%d %d %d\n'

    def record(self, msg, arrival_ns=None):
        """msg: the setpoint; arrival_ns: its datagram's kernel receive time (Unix ns) or None."""
        now_ns = time.time_ns()
        if arrival_ns is None:
            arrival_ns = now_ns
        read_ns = self.clock_ns(now_ns)
        speed = 1.0 if self.simulated is None else self.simulated.speed
        self.rows.append((read_ns - int((now_ns - arrival_ns) * speed), msg.time_boot_ms, read_ns))


class StallLog(_BenchLog):
    """For the benchmark: each time the loop fell behind its clock and skipped steps (loop.STALL_S), when
    (ns), how far behind (ms of the simulator's clock) and how many steps of each vehicle, written beside
    the setpoint log (stalls-<instance>.txt, empty when none): a vehicle whose steps were skipped did not
    send PX4's stream meanwhile, whatever the setpoints' arrival says."""

    row_format = '%d %.1f %d\n'

    def __init__(self, clock=None):
        super().__init__(None, clock)  # the path is given at write(): the same stalls for each vehicle

    def record(self, behind_s, skipped):
        self.rows.append((self.clock_ns(time.time_ns()), behind_s * 1e3, skipped))


class BenchLogs:
    """The benchmark's logs of `sims` (sim.autopilot.SimulatedPx4, instances `first_instance` on), written into
    `directory` at write(): a SetpointLog for each vehicle, fed by its setpoint_probes, and one StallLog for the
    loop that runs them all (`on_stall`), written for each vehicle."""

    def __init__(self, sims, directory, first_instance, clock):
        self.directory, self.first_instance, self.count = directory, first_instance, len(sims)
        self.stalls = StallLog(clock)
        self.setpoints = []
        for instance, sim in enumerate(sims, first_instance):
            setpoint_log = SetpointLog(os.path.join(directory, 'setpoints-%d.txt' % instance), clock)
            if not all([link.stamp_arrivals() for link in sim.links]):
                logging.warning('this kernel does not stamp datagrams (SO_TIMESTAMPNS): the setpoint log takes '
                                'arrivals as the simulator read them')
            sim.setpoint_probes.append(
                lambda msg, link, setpoint_log=setpoint_log: setpoint_log.record(msg, link.arrival_ns))
            self.setpoints.append(setpoint_log)

    def on_stall(self, behind_s, skipped):
        """sim.loop.run_together's on_stall."""
        self.stalls.record(behind_s, skipped)

    def write(self):
        for setpoint_log in self.setpoints:
            setpoint_log.write()
        for instance in range(self.first_instance, self.first_instance + self.count):
            # the loop's stalls are every vehicle's of this process
            self.stalls.write(os.path.join(self.directory, 'stalls-%d.txt' % instance))
