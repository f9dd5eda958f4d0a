"""Control: the torque sources of :func:`dynamics.simulate` and the passive joint torques, one module per
concern (issue 22's split of ``torques.py``).  Users import them from :mod:`dynamics.torques`, their public face.

==========================  ======================================================================================
:mod:`.sources`             the user-facing classes (:class:`~.sources.PD`, ...) and the compiled ``Source``
:mod:`.validation`          ``make_source``: the user's argument checked and turned into a ``Source``
:mod:`.dispatch`            the compiled evaluation of each kind, selected at compile time by the kind's tag
:mod:`.interpolation`       the references' interpolation (quintic Hermite)
:mod:`.passive`             damping, friction and limit springs
:mod:`.registry`            Python-callable torques, reached from compiled code through ``objmode``
:mod:`.operational_space`   the operational-space controller (Khatib)
==========================  ======================================================================================
"""
