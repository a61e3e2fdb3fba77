"""The data nxtnav ships: maps, sweep sets and sonar profiles, with the notices of third-party files.

An installed nxtnav carries this folder as the package ``toolkit.data`` (setup.py); read it through
`toolkit.world.bundled`, never by a path relative to the source tree. NOTICES.md lists every folder
here that holds files made elsewhere and the licence each comes under.
"""
