"""Formulations: each module states its model as an explicit QP or linear system."""
