"""The External Events Manager (paper IV-B): outside events become percepts, in order, once."""
