"""Supervision: OTP-style restart policies for component processes and pykka actors."""
