"""A child process whose output (stdout and stderr) is collected line by line, with bounded waits."""

import os
import signal
import subprocess
import threading
import time


class OutputProcess:
    """Popen(args) with its output read by a thread into `lines`.

    With new_session=True the child leads a process group of its own, and stop() signals the
    whole group (as Ctrl-C in a terminal does) and kills what is left of it: a roslaunch killed
    alone would leave its nodes running.
    """

    def __init__(self, args, env=None, new_session=False):
        self.args = list(args)
        self.new_session = new_session
        self.proc = subprocess.Popen(self.args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     start_new_session=new_session)
        self.lines = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.append(line.rstrip())

    @property
    def output(self):
        return '\n'.join(self.lines)

    def has_line(self, text):
        return any(text in line for line in self.lines)

    def wait_for_line(self, text, timeout_s):
        """True once a line contains text; False after timeout_s or once the process has exited without it."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.has_line(text):
                return True
            if self.proc.poll() is not None:
                self._reader.join(1.0)
                break
            time.sleep(0.1)
        return self.has_line(text)

    def expect_line(self, text, timeout_s):
        """Like wait_for_line, but raise AssertionError with the output's end when the line does not come."""
        if not self.wait_for_line(text, timeout_s):
            raise AssertionError('%r not said within %.0f s by %s; output:\n%s'
                                 % (text, timeout_s, ' '.join(self.args), self.output[-3000:]))

    def wait_exit(self, timeout_s):
        """The exit code, or None after killing a process still running after timeout_s."""
        try:
            code = self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self._kill()
            return None
        self._reader.join(1.0)
        return code

    def _signal(self, sig):
        """sig to the child, or with new_session to its group (no error once the group is gone)."""
        if not self.new_session:
            self.proc.send_signal(sig)
            return
        try:
            os.killpg(self.proc.pid, sig)
        except ProcessLookupError:
            pass

    def _kill(self):
        self._signal(signal.SIGKILL)
        self.proc.wait()

    def stop(self, sig=signal.SIGTERM, timeout_s=5.0):
        """Send sig unless it has exited, kill it after timeout_s; return the exit code.
        With new_session, sig goes to the group, and whatever of the group outlives the child is killed."""
        if self.proc.poll() is None:
            self._signal(sig)
            try:
                self.proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self._kill()
        if self.new_session:
            self._signal(signal.SIGKILL)
        self._reader.join(1.0)
        return self.proc.returncode
