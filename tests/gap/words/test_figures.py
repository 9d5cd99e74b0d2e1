"""The report's figures: matplotlib is loaded when a figure is drawn, not with the gap package."""

import subprocess
import sys


def test_a_diagnosis_without_a_report_never_loads_matplotlib():
    code = ("import sys; import svrqp.gap, svrqp.gap.words.figures, svrqp.gap.words.report; "
            "print('matplotlib' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "False"
