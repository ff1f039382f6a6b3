"""PX4's logger for the simulated PX4: a ULog file (sim.ulog) for each flight, as PX4 main 02e73e3b6f writes one
(src/modules/logger/logger.cpp, log_writer_file.cpp, util.cpp; PX4 SITL starts it as ROMFS/px4fmu_common/
init.d/rc.logging does: `logger start -b 1000 -t`, -e for SDLOG_MODE 1).

When (Logger::start_stop_logging, the mode read at boot): SDLOG_MODE 0 from each arming to its disarm; 1, PX4
SITL's, from boot until the first disarm, then from each arming to its disarm; 2 from boot to shutdown; 4 from
the first arming to shutdown; 3 (RC AUX1) never, the simulator has no AUX channel. A disarm ends the log 1 s
later (the logger measures the process load first, initialize_load_output), and an arming within that second
starts the next log at once. SDLOG_BACKEND without its file bit: no files. sim.logger_status says when
SYS_STATUS shows the logger running, from the recordings.

Where: LOG_ROOT/YYYY-MM-DD/HH_MM_SS.ulg, the UTC wall time at the start plus SDLOG_UTC_OFFSET minutes
(get_log_file_name with -t; PX4 SITL's LOG_ROOT is ./log in its working folder), said on the links as PX4 says
it ("[logger] ./log/...", mavlink_log_info). At boot, the oldest dated folders are removed while there are more
than SDLOG_DIRS_MAX (0: no limit) or less than 300 MiB (a tenth of a smaller disk) is free, and with less than
50 MiB free nothing is logged (util::check_free_space).

What, in PX4's order: the file header with the boot time of the start, the flag bits, the INFO of write_version
as PX4 SITL writes them (no sys_uuid and no sys_mcu: BOARD_HAS_NO_UUID and no MCU version on POSIX), the
FORMAT of each subscription and of the event topic, every parameter (PARAMETER), PX4 SITL's value of each
parameter set to another (PARAMETER_DEFAULT as the setup's default; PX4 also writes the system-wide defaults,
which the simulator does not know), ADD_LOGGED_MSG for each; then each cycle the samples of
sim.logged_topics' subscriptions as their publishers and intervals allow, vehicle commands and their
acknowledgements as they come, a LOGGING message for each text of PX4's mavlink_log (mavlink_log_* also print
to PX4's console, which the logger records with px4_log's levels), the parameters changed since, and a SYNC
every 500 ms.

How: the loop only packs samples into a buffer, which goes about once a second (HAND_OVER_S) to a thread of the
log's own that creates the folder, opens the file and writes (log_writer_file.cpp's writer thread). An error
there is one warning naming the file, and the flight goes on without that log.

Not written: perf counters, the boot console output, the events file and their INFO_MULTIPLE messages, the
excluded optional topics, the event topic's samples, the mission log (SDLOG_MISSION), MAVLink log streaming
(LOGGING_START), a restart after a write error, fsync.
"""

import logging
import os
import queue
import re
import shutil
import threading
import time

from offboard_py import param_codec
from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import logged_topics, ulog
from offboard_py.sim import uorb_topics as topics
from offboard_py.sim.logged_topics import us
from offboard_py.sim.mavlink.system_messages import PX4_OS_SW_VERSION, PX4_VERSION

log = logging.getLogger('offboard_py.sim')

SDLOG_MODE_WHILE_ARMED, SDLOG_MODE_BOOT_UNTIL_DISARM, SDLOG_MODE_BOOT_UNTIL_SHUTDOWN = 0, 1, 2
SDLOG_MODE_RC_AUX1, SDLOG_MODE_ARM_UNTIL_SHUTDOWN = 3, 4
SDLOG_BACKEND_FILE = 1
STOP_DELAY_S = 1.0            # initialize_load_output: the postflight load is measured for 1 s
SYNC_PERIOD_S = 0.5           # a SYNC message every 500 ms
PARAMS_CHECK_S = 0.1          # how often the simulator looks for changed parameters (PX4: at each update)
WRITE_CHUNK = 4096            # LogWriterFile::_min_write_chunk
# The buffer goes to the writer at most this often (and whenever it holds MAX_BUFFER): each hand-over wakes the
# writer's thread, which costs the loop some 10 us a cycle at PX4's 4 KB. PX4's writer syncs its file at least
# every second (log_writer_file.cpp), so the size a log listing shows lags by about as much on PX4.
HAND_OVER_S = 1.0
MAX_BUFFER = 256 * 1024
JOIN_TIMEOUT_S = 5.0
MIN_FREE_BYTES = 300 << 20    # util::check_free_space: free this much (or a tenth of the disk) by removing logs ...
MIN_FREE_FRACTION = 10
NO_LOG_FREE_BYTES = 50 << 20  # ... and under this do not log
DATED_FOLDER = re.compile(r'^(\d+)-(\d+)-(\d+)')
PX4_ROOT_WORDS = './log'      # how PX4 SITL names its log root in its texts
# What PX4 SITL's write_version writes (src/lib/version/version.c): the recorded commit, its branch, the board,
# Linux with the kernel version and the firmware version of AUTOPILOT_VERSION (sim.mavlink.system_messages),
# Debian 12's GCC
VERSION_INFO = (
    ('char', 'ver_sw', '02e73e3b6f4826a376d0805ee12e30b7538ada99'),
    ('uint32_t', 'ver_sw_release', PX4_VERSION),
    ('char', 'ver_hw', 'PX4_SITL'),
    ('char', 'sys_name', 'PX4'),
    ('char', 'sys_os_name', 'Linux'),
    ('char', 'ver_sw_branch', 'main'),
    ('uint32_t', 'sys_os_ver_release', PX4_OS_SW_VERSION),
    ('char', 'sys_toolchain', 'GNU GCC'),
    ('char', 'sys_toolchain_ver', '12.2.0'),
    ('uint32_t', 'ver_data_format', 2),
)
# px4_log's levels for what mavlink_log_* print with the text (systemlib/mavlink_log.h: info -> PX4_INFO,
# warning and critical -> PX4_WARN, emergency -> PX4_ERR; px4_log.cpp: INFO 6, WARN 4, ERROR 3)
LOGGING_LEVELS = {mavlink.MAV_SEVERITY_EMERGENCY: 3, mavlink.MAV_SEVERITY_ALERT: 3,
                  mavlink.MAV_SEVERITY_CRITICAL: 4, mavlink.MAV_SEVERITY_ERROR: 3,
                  mavlink.MAV_SEVERITY_WARNING: 4, mavlink.MAV_SEVERITY_NOTICE: 6, mavlink.MAV_SEVERITY_INFO: 6,
                  mavlink.MAV_SEVERITY_DEBUG: 7}


def log_file_name(utc_s, utc_offset_min=0):
    """('YYYY-MM-DD', 'HH_MM_SS.ulg') for a log started at utc_s (Unix seconds), as PX4 names it."""
    tm = time.gmtime(int(utc_s) + utc_offset_min * 60)
    return time.strftime('%Y-%m-%d', tm), time.strftime('%H_%M_%S', tm) + '.ulg'


def check_free_space(log_root, max_dirs, say):
    """util::check_free_space at boot: remove the oldest dated folders of log_root while there are more than
    max_dirs (0: any number) or too little is free; False when too little is left to log."""
    max_dirs = max_dirs if max_dirs > 0 else float('inf')
    while True:
        fs = os.statvfs(log_root)
        free = fs.f_bavail * fs.f_frsize
        dated = []
        for name in os.listdir(log_root):
            match = DATED_FOLDER.match(name)
            if match:
                dated.append((tuple(int(n) for n in match.groups()), name))
        min_free = min(MIN_FREE_BYTES, fs.f_blocks * fs.f_frsize // MIN_FREE_FRACTION)
        if not dated or (len(dated) <= max_dirs and free >= min_free):
            break
        oldest = os.path.join(log_root, min(dated)[1])
        log.info('removing log directory %s to get more space (left=%u MiB)', oldest, free >> 20)
        try:
            shutil.rmtree(oldest)
        except OSError as err:
            log.warning('cannot remove the log directory %s: %s', oldest, err)
            break
    if free < NO_LOG_FREE_BYTES:
        say(mavlink.MAV_SEVERITY_CRITICAL, '[logger] Not logging; SD almost full: %u MiB\t' % (free >> 20))
        return False
    return True


class FileWriter:
    """One log file, written by a thread of its own: `write(data)` queues bytes, `close()` ends the file."""

    def __init__(self, path):
        self.path = path
        self._queue = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name='sim-logger-writer', daemon=True)
        self._thread.start()

    def write(self, data):
        self._queue.put(data)

    def close(self):
        self._queue.put(None)

    def join(self, timeout_s):
        self._thread.join(timeout_s)
        return not self._thread.is_alive()

    def _run(self):
        try:
            os.makedirs(os.path.dirname(self.path), exist_ok=True)
            out = open(self.path, 'wb', buffering=0)
        except OSError as err:
            self._give_up('cannot create the log file %s: %s' % (self.path, err))
            return
        with out:
            while True:
                data = self._queue.get()
                if data is None:
                    return
                try:
                    out.write(data)
                except OSError as err:
                    self._give_up('cannot write the log file %s: %s' % (self.path, err))
                    return

    def _give_up(self, why):
        log.warning('%s; flying on without this log', why)
        while self._queue.get() is not None:  # what the loop still hands over is dropped
            pass


class _Subscription:
    def __init__(self, topic, msg_id, interval_ms):
        self.topic, self.msg_id, self.interval_us = topic, msg_id, interval_ms * 1000
        self.header = ulog.data_header(msg_id, topic.size)
        self.last_us = 0  # SubscriptionInterval::_last_update


class Logger:
    """The logger of the simulated PX4 whose flight stack is `flight` (sim.flight.Flight) around `origin`
    (sim.geo.GeoOrigin), with `params` (sim.param_store.ParamStore) and `system_id`, booted at now_s (seconds
    since boot, usually 0): ULog files under log_root; `say(severity, text)` puts a text on the links. The
    autopilot calls `boot(now_s)` once, then `step(now_s, status)` every cycle, `on_events()` with what the
    flight stack said, `on_text()` with each text it says, `on_vehicle_command()` and `on_vehicle_command_ack()`
    as the receiver takes and answers commands, and `close()` at shutdown. `wall_clock` gives UTC (Unix
    seconds) for the names and the boot time."""

    def __init__(self, log_root, params, flight, origin, system_id, now_s, say, wall_clock=time.time):
        self.log_root, self.params, self.flight, self.say = log_root, params, flight, say
        self.wall_clock = wall_clock
        self.boot_utc_us = us(wall_clock() - now_s)
        self.topics = logged_topics.FlightTopics(flight, origin, params, system_id)
        self.subscriptions = [_Subscription(topic, msg_id, interval)
                              for msg_id, (topic, interval) in enumerate(logged_topics.SUBSCRIPTIONS)]
        self.by_name = {sub.topic.name: sub for sub in self.subscriptions}
        self.polled = [(sub, self.topics.publishers[sub.topic.name]) for sub in self.subscriptions
                       if sub.topic.name in self.topics.publishers]  # the rest are handed in as they come
        self.event_msg_id = len(self.subscriptions)
        self.mode = params['SDLOG_MODE']
        self.enabled = bool(params['SDLOG_BACKEND'] & SDLOG_BACKEND_FILE) and self._prepare_root()
        self.start_state = False  # Logger::_prev_file_log_start_state
        self.writer, self.buffer = None, bytearray()
        self.writers = []         # those not yet joined
        self.stop_s = None        # the delayed stop after a disarm
        self.sync_s = self.params_s = self.handed_s = None
        self.logged_params = {}

    def boot(self, now_s):
        """The logger starts: a log from boot in the modes that log from boot."""
        if self.mode in (SDLOG_MODE_BOOT_UNTIL_DISARM, SDLOG_MODE_BOOT_UNTIL_SHUTDOWN):
            self._start(now_s)

    def _prepare_root(self):
        try:
            os.makedirs(self.log_root, exist_ok=True)
            return check_free_space(self.log_root, self.params['SDLOG_DIRS_MAX'], self.say)
        except OSError as err:
            log.warning('cannot use the log folder %s: %s; no logs', self.log_root, err)
            return False

    # -- the cycle -------------------------------------------------------------------------------

    def step(self, now_s, status=None):
        """One cycle at now_s; `status` the flight's Status at now_s if already built."""
        self._start_stop(now_s, self.flight.commander.armed)
        if self.writer is None:
            return
        if self.stop_s is not None and now_s >= self.stop_s:
            self._stop()
            return
        st = self.flight.status(now_s) if status is None else status
        self.topics.track(now_s, st)
        t_us = us(now_s)
        for sub, publish in self.polled:
            if sub.interval_us and t_us - sub.last_us < sub.interval_us:
                continue
            values = publish(now_s, st)
            if values is None:
                continue
            if sub.interval_us:  # SubscriptionInterval::copy: on schedule, never more than an interval behind
                sub.last_us = min(max(sub.last_us + sub.interval_us, t_us - sub.interval_us), t_us)
            self.buffer += sub.header
            self.buffer += sub.topic.pack(values)
        if self.stop_s is None and now_s - self.params_s >= PARAMS_CHECK_S:
            self._changed_parameters(now_s)  # write_changed_parameters: not after the disarm
        if now_s - self.sync_s > SYNC_PERIOD_S:
            self.sync_s = now_s
            self.buffer += ulog.sync()
        if (len(self.buffer) >= WRITE_CHUNK and now_s - self.handed_s >= HAND_OVER_S) or \
                len(self.buffer) >= MAX_BUFFER:
            self.handed_s = now_s
            self._hand_over()

    def _start_stop(self, now_s, armed):
        if self.mode in (SDLOG_MODE_BOOT_UNTIL_SHUTDOWN, SDLOG_MODE_RC_AUX1):
            return
        desired = armed or (self.start_state and self.mode == SDLOG_MODE_ARM_UNTIL_SHUTDOWN)
        if desired == self.start_state:
            return
        self.start_state = desired
        if desired:
            if self.stop_s is not None:  # armed again while the last log was closing
                self._stop()
            self._start(now_s)
        elif self.writer is not None:
            self.stop_s = now_s + STOP_DELAY_S

    # -- what the autopilot hands in -------------------------------------------------------------

    def on_events(self, events):
        """What the flight stack said (sim.events): the arming reasons for vehicle_status."""
        for event in events:
            if isinstance(event, ev.ArmingChanged):
                self.topics.on_arming(event.armed, event.reason)

    def on_text(self, severity, text, now_s):
        """A text PX4's mavlink_log says (STATUSTEXT): a LOGGING message."""
        if self.writer is not None:
            self.buffer += ulog.logging(LOGGING_LEVELS.get(severity, 6), us(now_s), text)

    def on_vehicle_command(self, values):
        """A vehicle_command as the receiver publishes it (logged_topics.command_message, set_mode_message)."""
        self._pushed(topics.VEHICLE_COMMAND.name, values)

    def on_vehicle_command_ack(self, values):
        self._pushed(topics.VEHICLE_COMMAND_ACK.name, values)

    def _pushed(self, name, values):
        if self.writer is not None:
            sub = self.by_name[name]
            self.buffer += sub.header
            self.buffer += sub.topic.pack(values)

    def close(self):
        """At shutdown: the log open ends, and what the writers have is written (a bounded wait)."""
        if self.writer is not None:
            self._stop()
        for writer in self.writers:
            if not writer.join(JOIN_TIMEOUT_S):
                log.warning('the log file %s was still being written at exit', writer.path)
        self.writers = []

    # -- a log file ------------------------------------------------------------------------------

    def _start(self, now_s):
        if not self.enabled or self.writer is not None:  # start_log_file: not while one is open (SDLOG_MODE 1)
            return
        folder, name = log_file_name(self.wall_clock(), self.params['SDLOG_UTC_OFFSET'])
        path = os.path.join(self.log_root, folder, name)
        self.writers = [w for w in self.writers if not w.join(0)]
        self.writer = FileWriter(path)
        self.writers.append(self.writer)
        self.stop_s = None
        self.sync_s = self.params_s = self.handed_s = now_s
        self.topics.restart()
        for sub in self.subscriptions:
            sub.last_us = 0
        self.buffer = bytearray(self._definitions(now_s))
        log.info('log file %s', path)
        self.say(mavlink.MAV_SEVERITY_INFO, '[logger] %s/%s/%s\t' % (PX4_ROOT_WORDS, folder, name))
        self._hand_over()

    def _stop(self):
        self.writer.write(bytes(self.buffer))
        self.writer.close()
        self.writer, self.buffer, self.stop_s = None, bytearray(), None

    def _hand_over(self):
        self.writer.write(bytes(self.buffer))
        self.buffer = bytearray()

    def _definitions(self, now_s):
        """Logger::start_log_file: header, version, formats, parameters and their defaults, subscriptions."""
        out = [ulog.file_header(us(now_s)), ulog.flag_bits()]
        out += [ulog.info(c_type, key, value) for c_type, key, value in VERSION_INFO]
        out.append(ulog.info('int32_t', 'time_ref_utc', self.params['SDLOG_UTC_OFFSET'] * 60))
        out.append(ulog.info('uint64_t', 'boot_time_utc_us', self.boot_utc_us))
        out += [ulog.format_definition(sub.topic.format) for sub in self.subscriptions]
        out.append(ulog.format_definition(topics.EVENT.format))
        self.logged_params = dict(self.params)
        out += [ulog.parameter(self._c_type(name), name, value) for name, value in self._in_order()]
        for name, value in self._in_order():
            default = self.params.definition(name).default
            if value != default:
                out.append(ulog.parameter_default(ulog.DEFAULT_CURRENT_SETUP, self._c_type(name), name, default))
        out += [ulog.add_logged_msg(sub.msg_id, 0, sub.topic.name) for sub in self.subscriptions]
        out.append(ulog.add_logged_msg(self.event_msg_id, 0, topics.EVENT.name))
        return b''.join(out)

    def _in_order(self):
        return ((name, self.params[name]) for name in self.params.names)

    def _c_type(self, name):
        return 'int32_t' if param_codec.is_integer(self.params.definition(name).type) else 'float'

    def _changed_parameters(self, now_s):
        self.params_s = now_s
        if self.params == self.logged_params:
            return
        for name, value in self._in_order():
            if self.logged_params.get(name) != value:
                self.buffer += ulog.parameter(self._c_type(name), name, value)
        self.logged_params = dict(self.params)
