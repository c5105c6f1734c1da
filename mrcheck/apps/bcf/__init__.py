"""BCF 2.1 (``.bcfzip``, buildingSMART's BIM Collaboration Format; 3.0 files are read too): the
issues of mrcheck -- the review's markers, the discrepancy suspects, the per-element deviation findings -- as topics
the BIM tools (Solibri, BIMcollab, Navisworks, BlenderBIM, Revit plug-ins) read, and back.

Written and read with the standard library (``xml.etree``, ``zipfile``) against the BCF 2.1
XML schemas (tests/data/bcf21/, validated in tests/test_bcf.py): the maintained Python library,
IfcOpenShell's ``bcf-client``, is GPL-3.0 (mrcheck is MIT) and pulls in ifcopenshell, xsdata
and requests for a few hundred lines of XML.

* ``model`` -- :class:`BcfTopic`, :class:`BcfComment`, :class:`BcfCamera` (the file's content);
* ``write`` -- :func:`bcf_bytes`: topics -> the bytes of a ``.bcfzip``;
* ``read`` -- :func:`read_bcf`: a ``.bcfzip`` -> topics (statuses and comments another tool changed),
  through ``archive`` (:class:`BcfArchive`: a zip read within limits, refusing zip bombs);
* ``topics`` -- :class:`Finding` (a marker or a suspect) -> :func:`finding_topic`;
* ``findings`` -- what mrcheck's results become: :func:`bcf_camera` from a shot's camera,
  :func:`priority` from a severity, :func:`topic_guid` (stable ids, so a round trip finds its
  topics again), :func:`element_component` (an IFC GlobalId only where the scene has one),
  :func:`element_label` (the element's name, class and storey, where a person reads it) and
  :func:`ifc_file_of` (the IFC file a scene came from, named in each topic's header).
"""

from mrcheck.apps.bcf.archive import BcfArchive
from mrcheck.apps.bcf.findings import (
    bcf_camera,
    default_author,
    element_component,
    element_label,
    ifc_file_of,
    ifc_global_id,
    info_label,
    priority,
    severity_of,
    topic_guid,
)
from mrcheck.apps.bcf.model import BcfCamera, BcfComment, BcfComponent, BcfTopic, SharedPicture
from mrcheck.apps.bcf.read import read_bcf, read_bcf_bytes, read_bcf_file
from mrcheck.apps.bcf.topics import Finding, finding_topic
from mrcheck.apps.bcf.write import bcf_bytes

__all__ = [
    "SharedPicture",
    "BcfArchive",
    "BcfTopic",
    "BcfComment",
    "BcfCamera",
    "BcfComponent",
    "bcf_bytes",
    "read_bcf",
    "read_bcf_bytes",
    "read_bcf_file",
    "bcf_camera",
    "priority",
    "severity_of",
    "topic_guid",
    "element_component",
    "element_label",
    "info_label",
    "default_author",
    "ifc_file_of",
    "ifc_global_id",
    "Finding",
    "finding_topic",
]
