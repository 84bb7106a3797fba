"""The paper suite (`iblcheck paper`): one module per experiment, eNN_<subject>.py, listed in number
order by registry.py; context.py is what each is handed, suite.py runs them into a report folder."""
