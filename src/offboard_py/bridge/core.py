"""What every bridge plugin is given: the FCU link, the ROS side, clocks, the connection.

A plugin is a class built with the Bridge and using only this interface:
- MAVLink: `on(msg_type, handler, accept=filters.SYSTEM, needed=None)`, `send(msg)`, `mav` (the
  codec that builds messages), `target_system`, `target_component`, `attitude` (the shared
  cache); `on_raw` (a frame, decoded when read), `on_frames` and `send_frame` (mavros's
  mavlink/from and mavlink/to); `listened(*publishers)` makes a `needed`; `commands` (the cmd
  plugin's COMMAND_ACK waiter, when loaded: `expect(cmd)` before sending a command nothing waits for);
  `command_long(cmd, params, confirmation)` (the cmd plugin's: send and wait for the ACK, (success, result));
- ROS: `publisher`, `subscriber`, `service`, `get_param`, `set_param`, `now()` (a stamp), `is_shutdown()`,
  all passed on to the `ros` object the Bridge is built with (rospy in the node, memory in offline tests);
  `fcu_stamp_ms`/`fcu_stamp_us` stamp FCU-timed data through the sys_time plugin's offset;
- time and connection: `monotonic_s()`, `every`, `after_connect`, `retry_while_connected`
  (bridge/scheduler.py holds the timers and the retry policy), `on_connection`, `connected`;
- `diagnostic(name, status)`: status() -> (level, message, [(key, value)]) for /diagnostics;
- `provide(name, what)`: what a plugin offers the others (`clock_offset`, `commands`, `command_long`).
One thread receives MAVLink and runs the handlers and the periodic work (`start()`); service
calls run in other threads and wait on events that thread sets. This module opens no
socket and reads no ROS parameter: node.py does that.
"""

import select
import threading
import time

import rospy

from offboard_py import wire
from offboard_py.bridge import filters
from offboard_py.bridge.attitude import Attitude
from offboard_py.bridge import scheduler
from offboard_py.bridge.scheduler import RETRY_DELAYS_S, TIMER_SLACK_S  # noqa: F401 (TIMER_SLACK_S: the tests')


WAIT_SLICE_S = 0.02  # wall seconds between looks at a deadline on the bridge's clock
MAX_WAIT_S = 0.2     # the receive loop's longest sleep in real time (how soon it sees stop())
RECEIVE_BATCH = 256  # datagrams read from one link before the due tasks run
# The receive loop waits on poll() and reads everything that has come when it wakes. Reading on a
# timer instead (every 4 ms while the FCU streams) woke the bridge more often on PX4's stream, not less:
# 324-326 wake-ups/s and 4.7-5.3 % of a core against 259-265 and 4.0-4.5 % (bench --replay, alternated,
# idle 2-core VM, 2026-11-25; bench/results/2026-11-25-bridge-cost.md): a poll often finds several
# datagrams waiting, a timed sleep always sleeps.

class Bridge:
    def __init__(self, cfg, link, ros, plugins=(), gcs=None, clock=time.monotonic):
        """`link` (and `gcs`) are MavlinkLinks, `ros` gives publisher/subscriber/service/now/is_shutdown,
        `clock` is the monotonic clock in seconds of every() and of connection timeouts."""
        self.cfg = cfg
        self.target_system = cfg['target_system_id']
        self.target_component = cfg['target_component_id']
        self.link = link
        # the codec whose xxx_encode() methods build what plugins send (the link packs and numbers it)
        self.mav = link.mav
        self.gcs = gcs
        if gcs:
            link.on_datagram = gcs.send_bytes     # FCU -> GCS, raw
            gcs.on_datagram = link.send_bytes     # GCS -> FCU, raw
        self._ros = ros
        self._clock = clock
        self.scheduler = scheduler.Scheduler(clock, rospy.logerr)  # every(), after_connect(): run_due()
        self.connection_epoch = 0  # counts connections: a retry loop ends with its own
        self.connected = False
        self._connection_listeners = []
        self.attitude = Attitude()
        # what one plugin offers the others (provide()): nothing until the plugin that offers it is loaded
        self.clock_offset = None  # sys_time's: stamp_ns(fcu_ns), read by fcu_stamp_*
        self.commands = None  # command's COMMAND_ACK waiter: expect(cmd) before sending a command itself
        self.command_long = None  # command's command_long(cmd, params, confirmation): COMMAND_LONG and its ACK
        self.diagnostics = [('FCU connection', self._connection_status)]  # (name, status function)
        self._last_io = (clock(), 0, 0)  # the FCU connection status's last time, bytes in and out
        # registered before any plugin's handler, so readers see this message's attitude
        self.on_raw('ATTITUDE_QUATERNION', self.attitude.update)
        self.plugins = [plugin(self) for plugin in plugins]
        self._running = False
        self.next_task_s = None  # when the receive loop must next run a task (bridge clock), for the governed clock
        # when the receive loop woke for datagrams it has not all read yet (bridge clock), else None: the
        # governed clock may not run far past it, so that a timeout (conn/timeout, a command's ACK) never
        # fires with the answer that ends it still unread in the socket
        self.unread_since_s = None
        self._thread = None

    # -- MAVLink ------------------------------------------------------------------------------

    def on(self, msg_type, handler, accept=filters.SYSTEM, needed=None):
        """Call handler(msg) for each `msg_type` message that `accept` (a filters.* function) lets through.
        `needed`: None (always), or a function saying whether the handler has anything to do now
        (e.g. `listened(publishers)`); the link decodes a type only while one of its handlers needs it.
        What a topic nobody subscribes to would have carried cannot be told apart from nothing."""
        def filtered(msg):
            if accept(msg, self.target_system, self.target_component):
                handler(msg)
        self.link.on(msg_type, filtered, needed)

    def on_raw(self, msg_type, hook):
        """Call hook(frame bytes) for each `msg_type` frame from the target system, decoded or not, before
        the handlers of the same message: a cache keeps the latest and decodes it when read
        (wire.decode_checked), as mavros's UAS keeps the latest attitude and IMU data."""
        target = self.target_system

        def filtered(frame):
            if (frame[5] if frame[0] == wire.MAGIC_V2 else frame[3]) == target:  # filters.SYSTEM on the header
                hook(frame)
        self.link.on_raw(msg_type, filtered)

    def on_frames(self, hook, needed=None):
        """Call hook(frame bytes) for every valid frame from the FCU link, any system's, read or not
        (mavros's mavlink/from), while `needed()` says so."""
        self.link.on_frames(hook, needed)

    def needs_changed(self):
        """What a handler's `needed` reads has moved (besides subscribers, which the link hears of):
        the link asks again at the next frame."""
        self.link.needs_changed()

    @staticmethod
    def listened(*publishers):
        """A `needed` for a handler that only feeds these (non-latched) topics: any subscriber."""
        return lambda: any(publisher.get_num_connections() for publisher in publishers)

    def send(self, msg):
        """Send to the FCU, in a datagram of its own as mavros does; False while its address is unknown."""
        return self.link.send(msg)

    def send_frame(self, frame):
        """Send a frame packed elsewhere as it is (mavros's mavlink/to), in a datagram of its own."""
        return self.link.send_bytes(frame)

    # -- ROS ----------------------------------------------------------------------------------

    def publisher(self, name, data_class, queue_size=10, latch=False):
        """A topic; when it gains or loses a subscriber the link asks the handlers' needed() again."""
        return self._ros.publisher(name, data_class, queue_size=queue_size, latch=latch,
                                   on_subscribers=self.needs_changed)

    def subscriber(self, name, data_class, callback):
        return self._ros.subscriber(name, data_class, callback)

    def service(self, name, service_class, handler):
        return self._ros.service(name, service_class, handler)

    def now(self):
        """A header stamp (ROS time)."""
        return self._ros.now()

    def get_param(self, name, default):
        """A ROS parameter (`~name` is the node's own)."""
        return self._ros.get_param(name, default)

    def set_param(self, name, value):
        """Set a ROS parameter (`~name` is the node's own)."""
        self._ros.set_param(name, value)

    def is_shutdown(self):
        return self._ros.is_shutdown()

    def node_name(self):
        """The node's resolved name, e.g. /mavros or /uav3/mavros."""
        return self._ros.node_name()

    def now_ns(self):
        return self.now().to_nsec()

    @staticmethod
    def time_from_ns(ns):
        return rospy.Time(ns // 1000000000, ns % 1000000000)

    def fcu_stamp_ms(self, time_boot_ms):
        """The header stamp of data the FCU timed in ms since its boot (mavros's synchronise_stamp)."""
        return self._fcu_stamp(time_boot_ms * 1000000)

    def fcu_stamp_us(self, time_usec):
        return self._fcu_stamp(time_usec * 1000)

    def _fcu_stamp(self, fcu_ns):
        ns = self.clock_offset.stamp_ns(fcu_ns) if self.clock_offset else None
        return self.now() if ns is None else self.time_from_ns(ns)

    # -- time and connection ------------------------------------------------------------------

    def monotonic_s(self):
        """The bridge's clock (s): monotonic wall time, or ROS time under /use_sim_time (as mavros's
        ros::Timer and ros::Time follow /clock). Every timeout and period of the plugins is on it."""
        return self._clock()

    def wait(self, event, timeout_s):
        """event.wait() up to timeout_s of the bridge's clock (in short wall slices, as that clock may run
        faster or slower than the wall); False on timeout or shutdown."""
        deadline = self._clock() + timeout_s
        while not event.wait(WAIT_SLICE_S):
            if self._clock() >= deadline or self.is_shutdown():
                return event.is_set()
        return True

    def every(self, period_s, callback):
        """Call callback(now_s) every period_s from the receive thread; returns the task (for take_early)."""
        return self.scheduler.every(period_s, callback)

    def take_early(self, task, now_s):
        """True, and the periodic task counted as run, when its next run is due within one period of now_s
        (scheduler.Scheduler.take_early)."""
        return self.scheduler.take_early(task, now_s)

    def run_due(self, now_s):
        """Run every task due at now_s: the periodic callbacks, then the one-shots after a connection."""
        self.scheduler.run_due(now_s)

    def run_periodic(self, now_s):
        """Run the periodic callbacks that are due at now_s (the receive loop's clock)."""
        self.scheduler.run_periodic(now_s)

    PROVIDED = ('clock_offset', 'commands', 'command_long')

    def provide(self, name, what):
        """A plugin offers `what` to the others under `name` (one of PROVIDED): the one way a plugin
        reaches another, so the bridge's attributes are its own."""
        if name not in self.PROVIDED:
            raise ValueError('provide(%r): not one of %s' % (name, ', '.join(self.PROVIDED)))
        setattr(self, name, what)

    def diagnostic(self, name, status):
        """Add a status to /diagnostics (named "<node>: <name>", e.g. "mavros: GPS"): status() -> (level,
        message, [(key, value)]), level a diagnostic_msgs/DiagnosticStatus level."""
        self.diagnostics.append((name, status))

    def _connection_status(self):
        """mavros's MavlinkDiag ("FCU connection"): its keys and summary, on the link's own counts
        (mavros's parser never counts a dropped packet and clears its parse errors at every byte, so it
        shows 0 for both; the bridge shows what it counted). So mavros's "N packeges dropped since last
        report" never comes: the summary is "connected", or "not connected" as a warning while the link is
        open. mavconn's speeds are the bytes since the last status over the whole seconds since then
        (duration_cast<seconds>): inf under a second."""
        stats, now_s = self.link.stats, self._clock()
        rx, tx = stats['bytes_received'], stats['bytes_sent']
        last_s, last_rx, last_tx = self._last_io
        self._last_io = (now_s, rx, tx)
        whole_s = float(int(now_s - last_s))

        def speed(count):
            return count / whole_s if whole_s else (float('inf') if count else float('nan'))
        values = [('Received packets:', stats['received']), ('Dropped packets:', stats['dropped']),
                  ('Buffer overruns:', 0), ('Parse errors:', stats['bad_frames']),
                  ('Rx sequence number:', self.link.last_seq((self.target_system, self.target_component))),
                  ('Tx sequence number:', self.link.mav.seq), ('Rx total bytes:', rx), ('Tx total bytes:', tx),
                  ('Rx speed:', '%f' % speed(rx - last_rx)), ('Tx speed:', '%f' % speed(tx - last_tx))]
        return (0, 'connected', values) if self.connected else (1, 'not connected', values)

    def on_connection(self, callback):
        """callback(connected) on every change of the FCU connection."""
        self._connection_listeners.append(callback)

    def after_connect(self, delay_s, callback):
        """Call callback() delay_s (bridge clock) after every new connection, in a thread of its own."""
        def start(connected):
            if connected:
                self.scheduler.after(delay_s, callback)
        self.on_connection(start)

    def retry_while_connected(self, what, attempt, delays=None):
        """attempt() -> (done, detail) until done, while this FCU connection lasts, backing off by `delays`
        (bridge clock; scheduler.retry). A failure with the link gone is an error (the next connection
        starts again). True once done."""
        epoch = self.connection_epoch
        pause = threading.Event()  # never set: a sleep on the bridge's clock that shutdown ends

        def stop():
            if self.is_shutdown():
                return ''
            if self.connection_epoch != epoch or not self.connected:
                return 'the FCU link is gone (tried again on the next connection)'
            return None
        return scheduler.retry(what, attempt, stop, lambda s: self.wait(pause, s), rospy, delays or RETRY_DELAYS_S)

    def set_connected(self, connected):
        if connected != self.connected:
            if connected:
                self.connection_epoch += 1
            self.connected = connected
            for callback in self._connection_listeners:
                callback(connected)

    # -- the receive thread -------------------------------------------------------------------

    def start(self):
        self._running = True
        self._thread = threading.Thread(target=self._loop, name='mavlink-receive', daemon=True)
        self._thread.start()

    def _loop(self):
        """Wake when a datagram comes or a task is due, not on a fixed tick: each wake-up of the
        process costs about as much as handling a datagram, and a wake-up reads all that has come.
        Under simulated time the bridge's clock is ROS time, whose seconds are not the wall's, so a
        wait is at most a short wall slice there."""
        poller = select.poll()
        links = {}
        for link in [self.link] + ([self.gcs] if self.gcs else []):
            links[link.fileno()] = link
            poller.register(link.fileno(), select.POLLIN)
        longest_wait_s = MAX_WAIT_S if self._clock is time.monotonic else WAIT_SLICE_S
        due_s = None  # the next wake-up the tasks need (bridge clock), worked out again after they run
        while self._running and not self.is_shutdown():
            if due_s is None or self.scheduler.added:
                due_s = self.scheduler.next_due_s()
            wait_s = longest_wait_s if due_s is None else min(longest_wait_s, max(0.0, due_s - self._clock()))
            self.next_task_s = due_s  # the governed clock may not run far past it before this loop runs it
            try:
                ready = poller.poll(wait_s * 1000.0)
                if ready and self.unread_since_s is None:
                    self.unread_since_s = self._clock()
                # a link read to its end (fewer than a batch: nothing was pending after the last) is caught up
                read = [links[fd].receive(RECEIVE_BATCH) for fd, _ in ready]  # every link, each time
                if all(count < RECEIVE_BATCH for count in read):
                    self.unread_since_s = None
            except (OSError, ValueError):
                break  # sockets closed at shutdown
            # most wake-ups are a datagram's: the tasks are looked at only once one is due
            now_s = self._clock()
            if due_s is not None and now_s >= due_s - TIMER_SLACK_S:
                self.run_due(now_s)
                due_s = None

    def stop(self):
        self._running = False
        if self._thread:
            self._thread.join(timeout=2.0)
        self.link.close()
        if self.gcs:
            self.gcs.close()
