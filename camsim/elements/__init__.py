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
    pair_mass,
    element_types,
    key_laws,
    laws_of,
    param,
    register,
    type_keys,
    variants,
)
# Registration order is the order of the docs and of messages: springs, links, contacts.
from camsim.elements.spring import Spring  # isort: skip
from camsim.elements.preloaded import PreloadedLink  # isort: skip
from camsim.elements.contact import Contact  # isort: skip
from camsim.elements.linear_contact import LinearContact  # isort: skip
from camsim.elements.power_contact import PowerContact  # isort: skip
from camsim.elements.rigid_contact import RigidContact  # isort: skip
from camsim.elements.adams_impact import AdamsImpactContact  # isort: skip
from camsim.elements.hertz_contact import HertzContact  # isort: skip
from camsim.elements.elastogap_contact import ElastoGapContact  # isort: skip
from camsim.elements.lash import Lash  # isort: skip
from camsim.elements.elastogap_lash import ElastoGapLash  # isort: skip
from camsim.elements.sided_lash import SidedLash  # isort: skip
from camsim.elements.friction import Friction  # isort: skip
from camsim.elements.rod import Rod  # isort: skip

__all__ = [
    "AdamsImpactContact", "CAM", "ElastoGapContact", "ElastoGapLash", "SidedLash", "Friction", "HertzContact", "Rod", "COMMON_PARAMS", "FIXED_NODES", "FORCE_TOL", "GROUND", "LENGTH_TOL",
    "Branch", "Contact", "Damping", "Element", "GuardKind", "Lash", "LinearContact", "Outcome", "Param",
    "PowerContact", "PreloadedLink", "RigidContact", "Spring",
    "classes", "element_class", "pair_mass", "element_types", "key_laws", "laws_of", "param", "register", "type_keys", "variants",
]
