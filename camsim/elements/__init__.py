"""Element kinds and contact laws, one module each, behind one protocol (:mod:`.base`).

Importing this package registers every kind; :func:`element_class` finds the class for
the ``type`` (and ``law``) written in a machine file.
"""

from camsim.elements.base import (
    CAM,
    COMMON_PARAMS,
    FIXED_NODES,
    FORCE_TOL,
    GROUND,
    LENGTH_TOL,
    Branch,
    Damping,
    Element,
    GuardKind,
    Outcome,
    Param,
    classes,
    element_class,
    element_types,
    key_laws,
    laws_of,
    param,
    type_keys,
)
from camsim.elements.contact import Contact
from camsim.elements.linear_contact import LinearContact
from camsim.elements.power_contact import PowerContact
from camsim.elements.preloaded import PreloadedLink
from camsim.elements.rigid_contact import RigidContact
from camsim.elements.spring import Spring

__all__ = [
    "CAM", "COMMON_PARAMS", "FIXED_NODES", "FORCE_TOL", "GROUND", "LENGTH_TOL",
    "Branch", "Contact", "Damping", "Element", "GuardKind", "LinearContact", "Outcome", "Param",
    "PowerContact", "PreloadedLink", "RigidContact", "Spring",
    "classes", "element_class", "element_types", "key_laws", "laws_of", "param", "type_keys",
]
