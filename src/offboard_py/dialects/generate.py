"""Regenerate px4_development.py from px4_development.xml with pymavlink's own generator.

    python -m offboard_py.dialects.generate          # rewrites src/offboard_py/dialects/px4_development.py

Run it after changing the XML or moving to another pymavlink (then also change
offboard_py.dialect.PYMAVLINK_TESTED), and commit the XML and the module together:
test/unit/test_dialect.py regenerates the module and fails on any difference.
"""

import contextlib
import io
import os
import shutil
import sys
import tempfile

from pymavlink.dialects import v20 as pymavlink_v20
from pymavlink.generator import mavgen, mavparse

HERE = os.path.dirname(os.path.abspath(__file__))
NAME = 'px4_development'  # the XML's and the module's name; mavgen names the DIALECT after the module
XML = os.path.join(HERE, NAME + '.xml')
MODULE = os.path.join(HERE, NAME + '.py')


class GenerateError(RuntimeError):
    """mavgen rejected the XML (its output says why)."""


def generate(output_dir):
    """Generate the dialect module from XML into OUTPUT_DIR/px4_development.py (what mavgen prints is
    kept, not printed); its path. Raises GenerateError with mavgen's output when mavgen fails."""
    with tempfile.TemporaryDirectory(prefix='offboard_py-mavgen-') as stage:
        # mavgen looks for an <include> beside the file that includes it: put our XML beside the
        # definitions pymavlink ships (development.xml and what it includes)
        shipped = os.path.dirname(os.path.abspath(pymavlink_v20.__file__))
        for name in os.listdir(shipped):
            if name.endswith('.xml'):
                shutil.copy(os.path.join(shipped, name), stage)
        shutil.copy(XML, stage)
        output = os.path.join(output_dir, NAME + '.py')
        opts = mavgen.Opts(output, wire_protocol=mavparse.PROTOCOL_2_0, language='Python3')
        chatter = io.StringIO()
        try:
            with contextlib.redirect_stdout(chatter), contextlib.redirect_stderr(chatter):
                ok = mavgen.mavgen(opts, [os.path.join(stage, NAME + '.xml')])
        except SystemExit:  # mavgen exits on some invalid XML
            ok = False
        if not ok:
            raise GenerateError('mavgen failed on %s:\n%s' % (XML, chatter.getvalue()))
    return output


def main():
    try:
        print(generate(HERE))
    except GenerateError as err:
        print(err, file=sys.stderr)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
