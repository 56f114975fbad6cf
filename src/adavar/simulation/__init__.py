"""Seeded noise generators and the Butterworth sections of a sensor's
bandwidth (the public face is :mod:`adavar.simulate`)."""
