"""The bundled sample data: the MakeHuman heads (`build_sample`, from the `makehuman` readers and FP
table) and the example stream (`make_demo_fap`)."""
