#!/usr/bin/env python3
"""The simulated PX4 alone: N vehicles in one simulator process (`sim_px4.py --vehicles N`), each driven
as a bridge drives it (HEARTBEAT at 1 Hz, TIMESYNC at 10 Hz as mavros's default, the tutorial's
SET_POSITION_TARGET_LOCAL_NED at 20 Hz, then OFFBOARD and arm), and its CPU measured over a window
in hover. No ROS: a quick side-by-side check of a change to the simulator (`--sim-src` runs another
checkout's src/), where `./run bench`'s fleet row carries every process and their noise.
The default is 16 vehicles: at 32 the one process takes 92-97 % of a core on the 2-core development
machine and hardly sleeps, so a cheaper simulator reads about the same there. A run varies by up to
15 %: at 16 vehicles the process runs one of two ways for seconds at a time (about 60-120 wake-ups a
second at 61-65 % of a core, or 500-620 at 51-52 %), so compare alternated runs, several each.

The driver binds each vehicle's bridge port on 127.0.0.1 (sitl_ports), so run it where those are
free, e.g. in a network namespace of its own: `unshare -n sh -c 'ip link set lo up; python3
bench/sim_fleet.py'`. The GCS links send to 14550 as PX4 SITL's do, to nobody here, as in
`./run bench`. Prints a table (with the datagrams each vehicle sent its bridge a second, least and median,
against real PX4 SITL's 404 on its onboard link: a simulator that falls behind skips steps and sends
fewer); exit 1 if a vehicle did not arm.
"""

import argparse
import json
import os
import select
import socket
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), 'src'))

from offboard_py import px4_modes, sitl_ports, wire  # noqa: E402
from offboard_py.dialect import mavlink  # noqa: E402
from offboard_py.testing.mavros_typemasks import POSITION_AND_YAW  # noqa: E402
from proc_stats import cpu_split_seconds, wakeups  # noqa: E402  (bench/ is not a package)

with open(os.path.join(os.path.dirname(HERE), 'reference', 'px4-sitl-census.json')) as census:
    # what real PX4 SITL sends on its onboard link a second, all its streams together (404)
    PX4_ONBOARD_DATAGRAMS_S = sum(json.load(census)['rates_hz'].values())
SETPOINT_PERIOD_S = 0.05     # the tutorial's 20 Hz
OFFBOARD_AFTER_S = 12.0      # the simulated PX4 is ready after its 4 s and the stream is steady
MAV_MODE_FLAG_SAFETY_ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED
HB_BASE_MODE = wire.HEADER_V2 + 6  # HEARTBEAT's base_mode in its frame (after custom_mode, type, autopilot)
PX4_OFFBOARD = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, px4_modes.MAIN_OFFBOARD)  # DO_SET_MODE's param1, 2


class Bridges:
    """One socket a vehicle on its bridge port, speaking as the bridge does."""

    def __init__(self, vehicles):
        self.links = []
        for i in range(vehicles):
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                sock.bind(('127.0.0.1', sitl_ports.bridge_port(i)))
            except OSError as err:
                sys.exit('sim_fleet: cannot bind the bridge port of vehicle %d (127.0.0.1:%d): %s; run it in a '
                         'network namespace of its own (see --help)' % (i, sitl_ports.bridge_port(i), err))
            sock.setblocking(False)
            mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=mavlink.MAV_COMP_ID_ONBOARD_COMPUTER)
            self.links.append((sock, mav, ('127.0.0.1', sitl_ports.fcu_port(i)), sitl_ports.system_id(i)))
        self.base_mode = {}
        self.received = [0] * vehicles  # datagrams from each vehicle's onboard link
        self.poller = select.poll()
        for sock, *_ in self.links:
            self.poller.register(sock.fileno(), select.POLLIN)

    def drain(self, wait_s):
        """Read what the vehicles sent (waiting up to wait_s), keeping each one's last HEARTBEAT base mode."""
        self.poller.poll(max(0.0, wait_s) * 1000.0)
        for i, (sock, *_) in enumerate(self.links):
            while True:
                try:
                    data = sock.recv(2048)
                except BlockingIOError:
                    break
                self.received[i] += 1
                # one message a datagram: a HEARTBEAT (id 0, bytes 7-9 of the header) carries base_mode at
                # payload byte 6; read in place, as the driver must cost the machine little beside the simulator
                if (len(data) > HB_BASE_MODE and data[0] == wire.MAGIC_V2 and data[7:wire.HEADER_V2] == b'\0\0\0'):
                    self.base_mode[i] = data[HB_BASE_MODE]

    def send(self, i, msg):
        sock, mav, fcu, _ = self.links[i]
        sock.sendto(msg.pack(mav), fcu)

    def tick(self, tick, elapsed_s, asking):
        """One 50 ms period of every bridge: the setpoint, a TIMESYNC every other, a HEARTBEAT every 20th,
        and while `asking`, OFFBOARD and arm every 5 s (as the tutorial's node asks)."""
        for i, (_, _, _, system_id) in enumerate(self.links):
            self.send(i, mavlink.MAVLink_set_position_target_local_ned_message(
                int(elapsed_s * 1000), system_id, 1, mavlink.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW,
                0.0, 0.0, -2.0, 0, 0, 0, 0, 0, 0, 0.0, 0))
            if tick % 2 == 0:
                self.send(i, mavlink.MAVLink_timesync_message(0, time.monotonic_ns()))
            if tick % 20 == 0:
                self.send(i, mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_ONBOARD_CONTROLLER,
                                                               mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0,
                                                               mavlink.MAV_STATE_ACTIVE))
            if asking and tick % 100 == 0 and not self.armed(i):
                self.send(i, mavlink.MAVLink_command_long_message(
                    system_id, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, *PX4_OFFBOARD, 0, 0, 0, 0, 0))
                self.send(i, mavlink.MAVLink_command_long_message(
                    system_id, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0))

    def armed(self, i):
        return bool(self.base_mode.get(i, 0) & MAV_MODE_FLAG_SAFETY_ARMED)

    def close(self):
        for sock, *_ in self.links:
            sock.close()


def run_once(args):
    env = dict(os.environ)
    src = os.path.abspath(args.sim_src) if args.sim_src else os.path.join(os.path.dirname(HERE), 'src')
    env['PYTHONPATH'] = src + os.pathsep + env.get('PYTHONPATH', '')
    bridges = Bridges(args.vehicles)
    sim = subprocess.Popen([sys.executable, '-c', 'from offboard_py.sim.main import main; raise SystemExit(main())',
                            '--vehicles', str(args.vehicles), '--log-level', 'warning'], env=env)
    try:
        start = time.monotonic()
        next_s, tick, window = start, 0, None
        while True:
            bridges.drain(next_s - time.monotonic())
            now = time.monotonic()
            if now < next_s:
                continue
            if sim.poll() is not None:
                sys.exit('sim_fleet: the simulator exited (%s)' % sim.returncode)
            elapsed = now - start
            bridges.tick(tick, elapsed, OFFBOARD_AFTER_S <= elapsed < args.warmup)
            tick, next_s = tick + 1, next_s + SETPOINT_PERIOD_S
            if window is None and elapsed >= args.warmup:
                window = now, cpu_split_seconds(sim.pid), wakeups(sim.pid), list(bridges.received)
            elif window is not None and now - window[0] >= args.duration:
                seconds = now - window[0]
                user, system = (b - a for a, b in zip(window[1], cpu_split_seconds(sim.pid)))
                armed = sum(bridges.armed(i) for i in range(args.vehicles))
                rates = sorted((b - a) / seconds for a, b in zip(window[3], bridges.received))
                return dict(armed=armed, cpu=(user + system) / seconds * 100, user=user / seconds * 100,
                            system=system / seconds * 100, wakeups=(wakeups(sim.pid) - window[2]) / seconds,
                            received=(rates[0], rates[len(rates) // 2]))
            if elapsed > args.warmup + args.duration + 30:
                sys.exit('sim_fleet: no measurement %.0f s after the start' % elapsed)
    finally:
        sim.terminate()
        try:
            sim.wait(10)
        except subprocess.TimeoutExpired:
            sim.kill()
        bridges.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--vehicles', type=int, default=16)
    parser.add_argument('--warmup', type=float, default=25.0, help='seconds from the start to the window (armed by then)')
    parser.add_argument('--duration', type=float, default=30.0, help='seconds of the window')
    parser.add_argument('--runs', type=int, default=1)
    parser.add_argument('--sim-src', metavar='DIR', help="another checkout's src/ to run the simulator from")
    args = parser.parse_args()
    if not 1 <= args.vehicles <= 39:
        parser.error('--vehicles must be 1..39 (the instances with ports of their own)')
    if args.warmup < OFFBOARD_AFTER_S + 8.0:
        parser.error('--warmup must leave the vehicles 8 s to arm after %.0f s' % OFFBOARD_AFTER_S)
    print('| run | vehicles | armed | simulator CPU (%% of one core) | user / system | a vehicle | wake-ups/s '
          '| datagrams/s a vehicle, least / median (PX4 SITL: %.0f) |' % PX4_ONBOARD_DATAGRAMS_S)
    print('|---|---|---|---|---|---|---|---|')
    failed = False
    for run in range(1, args.runs + 1):
        r = run_once(args)
        failed |= r['armed'] < args.vehicles
        print('| %d | %d | %d | %.1f | %.1f / %.1f | %.3f | %.0f | %.0f / %.0f |' % (
            run, args.vehicles, r['armed'], r['cpu'], r['user'], r['system'], r['cpu'] / args.vehicles,
            r['wakeups'], *r['received']), flush=True)
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
