"""JaxSim's `jaxsim.rbda` namespace, for code that reaches the contact models through it
(`jaxsim.rbda.contacts.SoftContacts` becomes `warpdyn.rbda.contacts.SoftContacts`). warpdyn's algorithms
themselves are Warp kernels (warpdyn.kernels), called through the façade."""

from . import contacts

__all__ = ["contacts"]
