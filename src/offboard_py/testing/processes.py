"""A child process whose output (stdout and stderr) is collected line by line, with bounded waits."""

import signal
import subprocess
import threading
import time


class OutputProcess:
    """Popen(args) with its output read by a thread into `lines`."""

    def __init__(self, args, env=None):
        self.args = list(args)
        self.proc = subprocess.Popen(self.args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
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
            self.proc.kill()
            self.proc.wait()
            return None
        self._reader.join(1.0)
        return code

    def stop(self, sig=signal.SIGTERM, timeout_s=5.0):
        """Send sig unless it has exited, kill it after timeout_s; return the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(1.0)
        return self.proc.returncode
