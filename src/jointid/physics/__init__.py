"""Physics: beam elements, assembled structures, natural modes and FRF synthesis.

The main API, re-exported here (imported on first use)::

    from jointid.physics import build_beam, natural_modes, synthesize_frf

* :mod:`.elements` -- ``Section``, ``Material``, ``timoshenko_element``;
* :mod:`.structure` -- ``Structure`` (immutable assembled model), ``ComplexStiffness``,
  ``build_beam``, ``constant_stiffness``;
* :mod:`.joints` -- ``parametric_joint``, ``build_joint``, ``JOINT_MODELS`` (joint models by type);
* :mod:`.frame` -- ``build_frame`` (3-D Timoshenko frames, 6 DOFs per node, sparse),
  ``FrameModel``, ``Member``, ``PointMass``; :mod:`.frame_sections` -- ``FrameSection``;
* :mod:`.reduction` -- ``craig_bampton``, ``CraigBamptonModel`` (boundary DOFs + modal scalar points);
* :mod:`.jointed_model` -- ``JointedModel`` (free model + joints by receptance coupling: the test article of any structure);
* :mod:`.elastomer_joint` -- ``ElastomerJoint`` (FE model of the elastomer cylinder between
  end caps), ``JointModes``; :mod:`.elastomer_material` -- ``ElastomerMaterial`` (a
  ``Material``), ``EndCap``, ``MATERIALS``;
* :mod:`.modes` -- ``Modes``, ``natural_modes``;
* :mod:`.synthesis` -- ``synthesize_frf`` (batched direct solve or modal superposition),
  ``receptance_direct``, ``receptance_modal``, ``choose_method``.

This layer imports only the labels and axes (:mod:`jointid.dofs`, :mod:`jointid.frequency`,
:mod:`jointid.frf`), never :mod:`jointid.methods` or anything above.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".elements": ("Section", "Material", "timoshenko_element"),
        ".structure": ("Structure", "ComplexStiffness", "build_beam", "constant_stiffness"),
        ".joints": ("parametric_joint", "build_joint", "JOINT_MODELS"),
        ".elastomer_joint": ("ElastomerJoint", "JointModes"),
        ".elastomer_material": ("ElastomerMaterial", "EndCap", "MATERIALS"),
        ".modes": ("Modes", "natural_modes"),
        ".frame": ("build_frame", "FrameModel", "Member", "PointMass"),
        ".frame_sections": ("FrameSection",),
        ".reduction": ("craig_bampton", "CraigBamptonModel"),
        ".jointed_model": ("JointedModel",),
        ".free_model": ("FreeModel", "StructureModel", "as_free_model"),
        ".beam_mesh": ("elements_per_segment", "bending_wavelength_m"),
        ".synthesis": ("synthesize_frf", "receptance_direct", "receptance_modal", "choose_method"),
    },
    submodules=("elements", "structure", "joints", "modes", "synthesis", "free_model", "beam_mesh", "banded_receptance",
                "elastomer_joint", "elastomer_material", "frame", "frame_sections", "reduction", "jointed_model"),
)
