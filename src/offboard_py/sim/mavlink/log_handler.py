"""The log protocol of the simulated PX4, as PX4 main 02e73e3b6f's MavlinkLogHandler answers it on each of its
links (src/modules/mavlink/mavlink_log_handler.cpp): the files of the log folder listed, downloaded, erased.

- LOG_REQUEST_LIST lists every regular file in every folder of the log root (any name, all dates, earlier
  runs' too), in the order the file system gives them (readdir), numbered from 0: a LOG_ENTRY each from
  `start` on (`end` is not looked at), with its size and modification time (UTC s), num_logs, and as
  last_log_num the request's `end`, or num_logs when `end` is 0xffff. Nothing is sent without a log root, nor
  for an empty one.
- LOG_REQUEST_DATA (id, ofs, count), once the logs were listed on this link: LOG_DATA of 90 bytes from ofs
  (the last one shorter at the end of the file) until count bytes are sent, rounded up to a whole
  LOG_DATA, or until the end of the file as listed; an id past the list, a file that cannot be opened, an
  offset at or past the end: no answer (PX4 only prints a debug line). ofs + count wrap as PX4's uint32 do.
- LOG_REQUEST_END stops the sending; LOG_ERASE deletes every file and folder under the log root (the log
  being written goes on into its unlinked file, as on PX4).
- Pacing: the handler's turn comes in the receiver's loop, at most every RECEIVER_SEND_PERIOD_S; each turn
  sends LOG_ENTRY or LOG_DATA until MAX_BYTES_BURST bytes of frames (a UDP link never reports its buffer
  full to PX4's handler: Mavlink::get_free_tx_buf). A client that reads slower loses datagrams, as from PX4,
  and asks again for what it is missing.
Requests are taken whatever their target, as PX4's handler does, and from anyone but LOG_ERASE, which changes
the vehicle and so is taken from the allowed systems only (sim.mavlink.receiver); answers go on the request's link.
"""

import logging
import os
import shutil

from offboard_py.sim.mavlink.streams import send_on

log = logging.getLogger('offboard_py.sim')

MAX_BYTES_BURST = 256 * 1024    # mavlink_log_handler.cpp
RECEIVER_SEND_PERIOD_S = 0.010  # MavlinkReceiver::run: the managers' send() when more than its 10 ms poll passed
LOG_DATA_BYTES = 90             # LOG_DATA.data
FRAME_OVERHEAD = 12             # MAVLINK_NUM_NON_PAYLOAD_BYTES of MAVLink 2 (no signature), as PX4 counts a frame
LOG_ENTRY_BYTES = 14            # sizeof(mavlink_log_entry_t): what PX4 counts for a LOG_ENTRY
LOG_DATA_PAYLOAD = 97           # MAVLINK_MSG_ID_LOG_DATA_LEN
NO_ID = 0xFFFF
UINT32 = 0xFFFFFFFF


def list_logs(log_root):
    """[(modification time, size, path)] of the files MavlinkLogHandler::create_log_list_file lists, in its
    order; None when the log root cannot be read."""
    entries = []
    try:
        folders = list(os.scandir(log_root))
    except OSError:
        return None
    for folder in folders:
        if not folder.is_dir(follow_symlinks=False) or folder.name in ('.', '..'):
            continue
        try:
            files = list(os.scandir(folder.path))
        except OSError:
            continue
        for entry in files:
            if not entry.is_file(follow_symlinks=False):
                continue
            try:
                info = os.stat(entry.path)
            except OSError:
                continue
            entries.append((int(info.st_mtime) & UINT32, info.st_size & UINT32, entry.path))
    return entries


def delete_all_logs(folder):
    """MavlinkLogHandler::delete_all_logs: the folders (not starting with '.') and files in `folder`."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        try:
            if entry.is_dir(follow_symlinks=False) and not entry.name.startswith('.'):
                shutil.rmtree(entry.path)
            elif entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
        except OSError as err:
            log.debug('cannot remove %s: %s', entry.path, err)


class LogHandler:
    """The log protocol on `link`, for the log root `log_root` (None: there is none); `mav` encodes the answers.
    The receiver hands it the four requests; `send(now_s, out)` is its turn in each cycle of the loop."""

    def __init__(self, log_root, mav, link):
        self.log_root, self.mav, self.link = log_root, mav, link
        self.state = 'idle'
        self.entries = []      # the list file PX4 writes (logdata.txt): (time_utc, size, path)
        self.num_logs = 0
        self.listed = False
        self.first_id = self.last_id = self.current_id = 0
        self.file = None       # the entry being sent: its id, size as listed, open file and offset
        self.file_id, self.file_size, self.offset = NO_ID, 0, 0
        self.request_ofs = self.request_count = 0
        self.finished = False  # _file_send_finished
        self.turn_s = None

    # -- requests ---------------------------------------------------------------------------------

    def on_request_list(self, msg):
        self.num_logs = 0
        entries = list_logs(self.log_root) if self.log_root else None
        if entries is None:
            return
        self.entries, self.num_logs = entries, len(entries)
        self.first_id = msg.start
        self.last_id = self.num_logs if msg.end == NO_ID else msg.end
        self.current_id = 0
        self.listed = True
        self.state = 'listing'

    def on_request_data(self, msg):
        if not self.listed or msg.id >= self.num_logs:
            self.state = 'idle'
            return
        if msg.id != self.file_id:
            self._close_file()
            if msg.id >= len(self.entries):  # the list is gone (LOG_ERASE)
                self.state = 'idle'
                return
            _, size, path = self.entries[msg.id]
            try:
                opened = open(path, 'rb')
            except OSError:
                return
            self.file, self.file_id, self.file_size = opened, msg.id, size
        if self.file is None or msg.ofs >= self.file_size:
            self.state = 'idle'
            return
        self.request_ofs, self.request_count = msg.ofs, msg.count
        self.offset = msg.ofs
        self.finished = False
        self.state = 'sending'

    def on_request_end(self, msg):
        self.state = 'idle'

    def on_erase(self, msg):
        if self.file is not None:
            self.file.close()
            self.file = None
        self.state = 'idle'
        self.entries = []
        if self.log_root:
            delete_all_logs(self.log_root)

    # -- the handler's turn ---------------------------------------------------------------------------

    def send(self, now_s, out=None):
        if self.turn_s is not None and now_s - self.turn_s < RECEIVER_SEND_PERIOD_S - 1e-6:
            return
        self.turn_s = now_s
        if self.state == 'idle':
            if self.file is not None and self.finished:
                self._close_file()
        elif self.state == 'listing':
            self._list(out)
        else:
            self._send_data(out)

    def _list(self, out):
        msgs, sent = [], 0
        for entry_id in range(self.current_id, len(self.entries)):
            self.current_id = entry_id + 1
            if entry_id < self.first_id:
                continue
            time_utc, size, _ = self.entries[entry_id]
            msgs.append(self.mav.log_entry_encode(entry_id, self.num_logs, self.last_id, time_utc, size))
            sent += LOG_ENTRY_BYTES
            if sent >= MAX_BYTES_BURST:
                send_on(self.link, msgs, out)
                return
        send_on(self.link, msgs, out)
        self.current_id = 0
        self.state = 'idle'

    def _send_data(self, out):
        msgs, sent = [], 0
        end = (self.request_ofs + self.request_count) & UINT32
        while sent < MAX_BYTES_BURST:
            if self.offset >= self.file_size:
                self.state = 'idle'
                break
            self.file.seek(self.offset)
            data = self.file.read(min(self.file_size - self.offset, LOG_DATA_BYTES))
            if not data:  # the file is shorter than listed: PX4 would send empty chunks on
                self.state = 'idle'
                break
            msgs.append(self.mav.log_data_encode(self.file_id, self.offset, len(data),
                                                 data.ljust(LOG_DATA_BYTES, b'\0')))
            sent += FRAME_OVERHEAD + LOG_DATA_PAYLOAD
            self.offset += len(data)
            self.finished = self.offset >= self.file_size
            if self.offset >= end or self.finished:
                self.state = 'idle'
                break
        send_on(self.link, msgs, out)

    def _close_file(self):
        if self.file is not None:
            self.file.close()
        self.file, self.file_id, self.file_size, self.offset = None, NO_ID, 0, 0
        self.request_ofs = self.request_count = 0

    def close(self):
        self._close_file()
