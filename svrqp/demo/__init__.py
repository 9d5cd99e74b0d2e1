"""``svrqp demo``: the papers' main results reproduced end to end on the embedded simulated data.

S0's MLR vs ε-SVR table, S1's GA-tuned ε-SVR, S4's LS-SVR straightness compensation, S2's
nine-line identification and δx models, S3's recursive least squares, the export and verification
of S0's ε-SVR, and the gap diagnosis of the summer model on the autumn batch — written to a fresh
directory with figures and ``report.html``. Every published number is set against ours in one
table of rows labelled from one vocabulary (:mod:`svrqp.demo.vocabulary`).
"""

from __future__ import annotations

from svrqp.demo.run import run_demo

__all__ = ["run_demo"]
