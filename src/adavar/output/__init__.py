"""Figures, the HTML report, exports and notebook views."""
